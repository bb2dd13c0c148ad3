"""What a family builds: parts made of convex solids, the holes cut from them, and the steps
of the assembly sequence. Pure data; nothing here touches the disk.

Every solid is a convex polytope given as half-space rows [n, d] meaning n . x <= d (unit
normals), in its part's frame. A part is the union of its solids minus the union of its
holes. A clearance hole for a part is the union of each of its solids with every plane moved
out by the clearance (assetgen.geometry.clearance_hole): outside it, a point is more than the
clearance from every solid, so the gap is exactly the clearance at the faces and never less.
The pieces a simulator collides are each solid carved by the holes
(assetgen.collision.carve): convex, exact, and never inside a hole.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from assetgen.core.frames import Frame


@dataclass(frozen=True)
class Part:
    """A rigid part: the union of `solids` minus the union of `holes`, both in the part
    frame.

    name   : unique within the assembly (file and body names derive from it).
    solids : convex solids, (k, 4) half-space rows each; they may overlap.
    holes  : convex holes cut from every solid, (k, 4) rows each (possibly unbounded).
    pose   : (4, 4) the part frame in the module frame where the part is assembled (for a
             moving part: its design pose, every gap at its clearance).
    print_turn : (3, 3) rotation of the part frame that prints it without supports (the
             3MF turns the part by it and rests it on the bed).
    shared_corners : the solids are pieces of one exact partition and meet at corners of
             it: part_mesh makes each such corner one point (assetgen.families.part_mesh.snap)
             before the union. False (every earlier family) leaves the solids as they are.
    """

    name: str
    solids: tuple[np.ndarray, ...]
    holes: tuple[np.ndarray, ...] = ()
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))
    print_turn: np.ndarray = field(default_factory=lambda: np.eye(3))
    shared_corners: bool = False


@dataclass(frozen=True)
class Step:
    """One insertion of the sequence.

    part      : the moving part's name.
    clearance : m, the gap between the part in its design pose and everything present.
    entrance  : where the insertion axis meets the receiving surface, z = surface normal.
    bottom    : the floor of the part's hole, z along the insertion axis (pointing out of the
                hole); the part's frame sits here, moved out by the clearance, when seated.
    travel    : m, how far the part moves along the axis from above the entrance to its
                design pose (the straight path the checks keep clear).
    """

    part: str
    clearance: float
    entrance: Frame
    bottom: Frame
    travel: float


@dataclass(frozen=True)
class Assembly:
    """A family's output: a static base, moving parts, and the order they go in.

    base  : the fixed part (plate, blocks), pose = identity (the module frame).
    parts : the moving parts, in their design poses.
    steps : one per moving part, in insertion order.
    """

    base: Part
    parts: tuple[Part, ...]
    steps: tuple[Step, ...]

    def part(self, name: str) -> Part:
        for p in (self.base, *self.parts):
            if p.name == name:
                return p
        raise KeyError(f"no part {name!r}; parts: {[p.name for p in (self.base, *self.parts)]}")

    def present_at(self, step: int) -> tuple[Part, ...]:
        """The parts in place while step `step` (0-based) inserts its part: the base and
        every part of an earlier step, in their design poses."""
        done = {s.part for s in self.steps[:step]}
        return (self.base, *(p for p in self.parts if p.name in done))
