"""Params in, solids and frames out: the peg, the plate with its hole, and the task frames.

Pure geometry: nothing here touches the disk. Construction (all exact up to float rounding):
- peg: the cross-section polygon at the top (z = h), (1 - taper) times it at the bottom (z = 0),
  joined by planar side faces; convex, in the peg frame.
- hole: in the design pose, every face plane of the peg (sides and bottom) moved out by the
  clearance (mitred corners), continued up through the mounting surface: a convex polytope.
- module: (plate U sleeve) - hole, where the sleeve is the hole's planes moved out by a
  further wall (floor) thickness, cut to the hole's bounding box, hanging below the plate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import manifold3d as mf
import numpy as np

from assetgen.core.frames import Frame
from assetgen.core.mesh import Mesh, cross3
from assetgen.core.portable import dot, matmul, norm
from assetgen.geometry.polytope import (
    interior_point,
    offset_planes,
    polytope_vertices,
    transform_planes,
)
from assetgen.params.module_params import ModuleParams, ParamError

FOOTPRINT_TOLERANCE = 1e-9
"""m a module may reach beyond its plate's footprint (rounding only)."""
HOLE_CAP_Z = 0.02
"""Height above the mounting surface (m) where the hole's solid is capped; only needs to be
above every point of the module so the cut opens at the top."""


class GeometryError(ParamError):
    """Valid-looking params whose module cannot be built (e.g. the hole leaves the plate)."""


class FootprintError(GeometryError):
    """Params whose sleeve would lean out of the plate's footprint (near some corners of
    Table I): refused by design, so a module is never wider than its plate."""


class ChamferError(FootprintError):
    """A peg chamfer too long for its peg's bottom face (its edges would cross): refused, and
    a sampled module is drawn again, as on a footprint refusal."""


CHAMFER_FILL = 0.8
"""A chamfer may move the bottom face's edges in by at most this share of the inset at which
its first edge would vanish (the face keeps its shape, a fifth of its size at least)."""


@dataclass(frozen=True)
class ModuleGeometry:
    """The solids and frames of one module. Meshes in metres.

    peg            : the peg in the peg frame.
    module         : plate with sleeve and hole, in the module frame.
    hole_planes    : (k, 4) rows [n, d], module frame: the hole is {x : n . x <= d} (uncapped).
    sleeve_planes  : (k, 4) the sleeve as half-spaces (see sleeve_half_spaces), module frame.
    hole_section   : (2, 2) rows lo, hi: the xy bounds of the hole between the plate's faces.
    entrance       : where the hole axis meets the mounting surface, z = surface normal.
    bottom         : centre of the hole floor, z along the hole axis; a seated peg's frame.
    design_pose    : the bottom frame moved up the axis by the clearance: every gap = clearance.
    """

    params: ModuleParams
    peg: Mesh
    module: Mesh
    hole_planes: np.ndarray
    sleeve_planes: np.ndarray
    hole_section: np.ndarray
    entrance: Frame
    bottom: Frame
    design_pose: Frame
    module_genus: int
    module_volume: float
    hole_chamfer_planes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    """(k - 1, 4) the entrance chamfer's faces, one a side face of the hole (module frame,
    unit normals, n . x <= d inside the chamfer's part of the hole); none without one."""


def cross_section(p: ModuleParams) -> np.ndarray:
    """Top cross-section polygon (n, 2), counter-clockwise, centred on the peg axis (m)."""
    k = np.arange(p.n_vertices)
    theta = 2 * np.pi * k / p.n_vertices
    pts = p.circumradius * np.column_stack([np.cos(theta), np.sin(theta)])
    c, s = math.cos(p.squash_angle), math.sin(p.squash_angle)
    rot = np.array([[c, -s], [s, c]])
    # Squash along the axis at squash_angle: R diag(aspect, 1) R^T keeps convexity and CCW order.
    squash = matmul(matmul(rot, np.diag([p.aspect_ratio, 1.0])), rot.T)
    return matmul(pts, squash.T)


def _corners(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A convex CCW polygon's (n, 2) unit vectors from each corner to the previous and the
    next corner, and the edge lengths (n,) from each corner to the next (elementwise
    arithmetic: the same bits on every CPU)."""
    prev = np.roll(polygon, 1, axis=0) - polygon
    nxt = np.roll(polygon, -1, axis=0) - polygon
    length = np.sqrt(nxt[:, 0] * nxt[:, 0] + nxt[:, 1] * nxt[:, 1])
    back = np.roll(length, 1)
    return prev / back[:, None], nxt / length[:, None], length


def chamfer_inset_limit(polygon: np.ndarray) -> float:
    """The inset (m) at which moving every edge of a convex CCW polygon in by it makes its
    first edge vanish: an edge shrinks by the inset times cot(a/2) at each end, a being the
    corner's interior angle."""
    u, w, length = _corners(polygon)
    cos = u[:, 0] * w[:, 0] + u[:, 1] * w[:, 1]
    sin = np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])
    cot_half = (1.0 + cos) / sin  # cot(a / 2) at each corner
    return float((length / (cot_half + np.roll(cot_half, -1))).min())


def _inset(polygon: np.ndarray, inset: float) -> np.ndarray:
    """The convex CCW polygon with every edge moved in by `inset` (m): each corner moves
    along its bisector by inset / sin(a / 2)."""
    u, w, _ = _corners(polygon)
    bis = u + w
    size = np.sqrt(bis[:, 0] * bis[:, 0] + bis[:, 1] * bis[:, 1])
    cos = u[:, 0] * w[:, 0] + u[:, 1] * w[:, 1]
    sin_half = np.sqrt((1.0 - cos) / 2.0)
    return polygon + (inset / sin_half)[:, None] * bis / size[:, None]


def chamfer_inset(p: ModuleParams) -> float:
    """How far the chamfer moves the bottom face's edges in (m); ChamferError where that is
    more than CHAMFER_FILL of the bottom face's limit."""
    inset = p.peg_chamfer * math.tan(p.peg_chamfer_angle)
    limit = CHAMFER_FILL * chamfer_inset_limit((1.0 - p.taper) * cross_section(p))
    if inset > limit:
        raise ChamferError(
            f"peg_chamfer = {p.peg_chamfer * 1e3:.3f} mm at {math.degrees(p.peg_chamfer_angle):g}"
            f" deg moves the peg's bottom edges in by {inset * 1e3:.3f} mm; this peg's bottom "
            f"face takes at most {limit * 1e3:.3f} mm: shorten the chamfer or flatten its angle"
        )
    return inset


def peg_mesh(p: ModuleParams) -> Mesh:
    """The peg as a closed mesh in the peg frame (bottom face centre at the origin)."""
    top = cross_section(p)
    n = len(top)
    bottom = (1.0 - p.taper) * top
    if p.peg_chamfer:
        return _chamfered_peg(p, top, bottom)
    v = np.vstack(
        [
            np.column_stack([bottom, np.zeros(n)]),
            np.column_stack([top, np.full(n, p.peg_height)]),
        ]
    )
    i = np.arange(n)
    j = (i + 1) % n
    sides = np.vstack([np.column_stack([i, j, n + j]), np.column_stack([i, n + j, n + i])])
    fan = np.arange(1, n - 1)
    bottom_faces = np.column_stack([np.zeros(n - 2, int), fan + 1, fan])
    top_faces = np.column_stack([np.full(n - 2, n), n + fan, n + fan + 1])
    return Mesh(v, np.vstack([sides, bottom_faces, top_faces]).astype(np.int64))


def _chamfered_peg(p: ModuleParams, top: np.ndarray, bottom: np.ndarray) -> Mesh:
    """The peg with its tip chamfered: the bottom face inset, each side face from
    `peg_chamfer` up, and between them one planar chamfer face a side (each side's edge at
    that height and its inset bottom edge are parallel)."""
    n = len(top)
    t = p.peg_chamfer / p.peg_height
    start = bottom + t * (top - bottom)  # the side faces' section at the chamfer's top
    layers = (_inset(bottom, chamfer_inset(p)), start, top)
    heights = (0.0, p.peg_chamfer, p.peg_height)
    v = np.vstack(
        [np.column_stack([xy, np.full(n, z)]) for xy, z in zip(layers, heights, strict=True)]
    )
    i = np.arange(n)
    j = (i + 1) % n
    bands = [
        np.vstack([np.column_stack([a + i, a + j, b + j]), np.column_stack([a + i, b + j, b + i])])
        for a, b in ((0, n), (n, 2 * n))
    ]
    fan = np.arange(1, n - 1)
    bottom_faces = np.column_stack([np.zeros(n - 2, int), fan + 1, fan])
    top_faces = np.column_stack([np.full(n - 2, 2 * n), 2 * n + fan, 2 * n + fan + 1])
    return Mesh(v, np.vstack([*bands, bottom_faces, top_faces]).astype(np.int64))


def peg_planes(p: ModuleParams) -> np.ndarray:
    """Face planes of the peg's sides and bottom, peg frame, rows [n, d] (n . x <= d inside).

    The hole is these planes moved out by the clearance. Above the peg's top it simply goes
    on along the side planes, which widen upward (the peg tapers toward its bottom), so a
    straight insertion along the axis never comes nearer than the clearance.
    """
    top = cross_section(p)
    n = len(top)
    h = p.peg_height
    bottom = (1.0 - p.taper) * top
    a0 = np.column_stack([bottom, np.zeros(n)])
    a1 = np.roll(a0, -1, axis=0)
    b0 = np.column_stack([top, np.full(n, h)])
    # All side normals in one call (np.cross's per-call overhead is most of the build's
    # numpy time); cross3 evaluates the same products in the same order, so the same bits.
    normals = cross3(a1 - a0, b0 - a0)
    rows = []
    for k in range(n):
        normal = normals[k] / norm(normals[k])
        rows.append([*normal, float(dot(normal, a0[k]))])
    rows.append([0.0, 0.0, -1.0, 0.0])
    return np.array(rows)


def hole_rotation(p: ModuleParams) -> np.ndarray:
    """Rotation (3, 3) of the bottom frame in the module frame: Rx(tilt_x) Ry(tilt_y) Rz(yaw)."""
    cx, sx = math.cos(p.hole_tilt_x), math.sin(p.hole_tilt_x)
    cy, sy = math.cos(p.hole_tilt_y), math.sin(p.hole_tilt_y)
    cz, sz = math.cos(p.hole_yaw), math.sin(p.hole_yaw)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return matmul(matmul(rx, ry), rz)


def task_frames(p: ModuleParams) -> tuple[Frame, Frame, Frame]:
    """(entrance, bottom, design_pose) in the module frame."""
    r = hole_rotation(p)
    axis = r[:, 2]
    entrance = np.array([p.hole_x, p.hole_y, 0.0])
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = entrance - p.hole_depth * axis
    bottom = Frame.from_matrix(m)
    m[:3, 3] += p.clearance * axis
    design = Frame.from_matrix(m)
    return Frame(tuple(entrance), (1.0, 0.0, 0.0, 0.0)), bottom, design


def _to_mesh(solid: mf.Manifold) -> Mesh:
    m = solid.to_mesh64()
    return Mesh(np.asarray(m.vert_properties)[:, :3].copy(), np.asarray(m.tri_verts, np.int64))


def _cap(z_max: float) -> np.ndarray:
    return np.array([[0.0, 0.0, 1.0, z_max]])


def sleeve_half_spaces(
    p: ModuleParams, hole_planes: np.ndarray, hole_vertices: np.ndarray, design_m: np.ndarray
) -> np.ndarray:
    """The sleeve (k, 4): every hole plane moved out by the wall (the floor by the floor
    thickness), cut to the hole's bounding box in the hole frame grown by the wall, below
    mid-plate (so its union with the plate is a clean solid).

    The mitred planes make the sleeve's convex decomposition exact and cheap (each wall piece
    lies beyond one hole plane); the box keeps the acute corners of squashed polygons from
    growing long mitred spikes. Every wall is at least `sleeve_wall` thick.
    """
    extra = np.full(len(hole_planes), p.sleeve_wall)
    extra[-1] = p.floor_thickness  # the floor plane is the last row of peg_planes
    local = matmul(hole_vertices - design_m[:3, 3], design_m[:3, :3])
    lo = local[:, :2].min(axis=0) - p.sleeve_wall
    hi = local[:, :2].max(axis=0) + p.sleeve_wall
    box = np.array(
        [[1, 0, 0, hi[0]], [-1, 0, 0, -lo[0]], [0, 1, 0, hi[1]], [0, -1, 0, -lo[1]]], float
    )
    return np.vstack(
        [
            offset_planes(hole_planes, extra),
            transform_planes(box, design_m),
            _cap(-p.plate_thickness / 2),
        ]
    )


def _body(
    p: ModuleParams, sleeve_planes: np.ndarray, bottom: np.ndarray, axis: np.ndarray
) -> tuple[mf.Manifold, np.ndarray | None]:
    """The plate with the sleeve under its hole, before the hole is cut, and the sleeve's
    vertices (None where the hole is too shallow to need one)."""
    t = p.plate_thickness
    plate = mf.Manifold.cube([p.plate_size, p.plate_size, t], center=True).translate([0, 0, -t / 2])
    floor_point = bottom - 0.5 * p.floor_thickness * axis
    if interior_point(sleeve_planes, floor_point) is None:
        return plate, None
    sleeve = polytope_vertices(sleeve_planes)
    return plate + mf.Manifold.hull_points(sleeve), sleeve


def entrance_chamfer_planes(p: ModuleParams, hole_planes: np.ndarray) -> np.ndarray:
    """The entrance chamfer's face over each side face of the hole (module frame, unit
    normals): with s = n . x - d the side's plane, the chamfer's part of the hole is
    s <= g (z + L), g = tan(angle), L its depth, z the height over the mounting surface. Every
    side opens at the same rate in s, so the material beyond side i is still one convex cell
    (beyond i, and beyond its chamfer face), as the exact decomposition needs."""
    if not p.hole_chamfer:
        return np.zeros((0, 4))
    g = math.tan(p.hole_chamfer_angle)
    sides = hole_planes[:-1]
    rows = np.column_stack([sides[:, :2], sides[:, 2] - g, sides[:, 3] + g * p.hole_chamfer])
    return rows / norm(rows[:, :3])[:, None]


def _hole_solid(hole_planes: np.ndarray, chamfer: np.ndarray, depth: float) -> mf.Manifold:
    """The hole (capped above the surface), with its entrance chamfer's part (down to `depth`
    below the surface, where it meets the side faces) where it has one."""
    hole = mf.Manifold.hull_points(polytope_vertices(np.vstack([hole_planes, _cap(HOLE_CAP_Z)])))
    if not len(chamfer):
        return hole
    bevel = np.vstack([chamfer, _cap(HOLE_CAP_Z), [[0.0, 0.0, -1.0, depth]]])
    return hole + mf.Manifold.hull_points(polytope_vertices(bevel))


def printed_module(geom: ModuleGeometry, offset: float) -> Mesh:
    """The module with its hole's faces moved out by `offset` (m) more, every other face as
    it is: the file to give a printer whose holes come out `offset` undersize."""
    p = geom.params
    hole = _hole_solid(
        offset_planes(geom.hole_planes, offset),
        offset_planes(geom.hole_chamfer_planes, offset),
        p.hole_chamfer,
    )
    axis = geom.bottom.matrix()[:3, 2]
    body, _ = _body(p, geom.sleeve_planes, np.array(geom.bottom.pos), axis)
    return _to_mesh(body - hole)


def build_module(p: ModuleParams) -> ModuleGeometry:
    """Build the peg, the module and the frames of `p` (validated first)."""
    p.validate()
    if p.peg_chamfer:
        chamfer_inset(p)  # a chamfer its peg cannot take is refused before any solid
    entrance, bottom, design = task_frames(p)
    design_m = design.matrix()
    axis = design_m[:3, 2]
    hole_planes = transform_planes(offset_planes(peg_planes(p), p.clearance), design_m)
    centre = np.array(design.pos) + 0.5 * p.hole_depth * axis
    capped = np.vstack([hole_planes, _cap(HOLE_CAP_Z)])
    inside = interior_point(capped, centre)
    if inside is None:
        raise GeometryError("the hole is empty for these parameters")
    hole_vertices = polytope_vertices(capped)

    half = p.plate_size / 2
    t = p.plate_thickness
    # The hole and its wall must stay inside the plate, or the plate's edge is cut open.
    slab = np.vstack([hole_planes, _cap(0.0), [[0.0, 0.0, -1.0, t]]])
    inside = interior_point(slab, np.array([p.hole_x, p.hole_y, -t / 2]))
    if inside is None:
        raise GeometryError(
            "the hole does not reach the mounting surface; increase hole_depth_fraction"
        )
    section = polytope_vertices(slab)[:, :2]
    chamfer = entrance_chamfer_planes(p, hole_planes)
    if len(chamfer):  # the entrance is wider: its section in the plate
        bevel = np.vstack([chamfer, slab[-2:], [[0.0, 0.0, -1.0, p.hole_chamfer]]])
        section = np.vstack([section, polytope_vertices(bevel)[:, :2]])
    extent = np.abs(section).max() + p.sleeve_wall
    if extent > half:
        raise GeometryError(
            f"the hole with its {p.sleeve_wall * 1e3:g} mm wall reaches {extent * 1e3:.2f} mm "
            f"from the plate centre, beyond the plate's edge at {half * 1e3:g} mm (clearance "
            f"{p.clearance * 1e3:g} mm, hole at ({p.hole_x * 1e3:.1f}, {p.hole_y * 1e3:.1f}) mm): "
            "reduce the clearance, the circumradius or the hole offset, or enlarge the plate"
        )

    sleeve_planes = sleeve_half_spaces(p, hole_planes, hole_vertices, design_m)
    if len(chamfer):
        hole = _hole_solid(hole_planes, chamfer, p.hole_chamfer)
    else:  # the hull of the vertices already at hand (Table I's bytes)
        hole = mf.Manifold.hull_points(hole_vertices)
    body, sleeve = _body(p, sleeve_planes, np.array(bottom.pos), axis)
    if sleeve is not None:
        # a tilted, deep hole leans out: the sleeve hanging below the plate must stay inside
        # the plate's footprint, or the module is wider than its plate (and its neighbours')
        reach = np.abs(sleeve[:, :2]).max()
        if reach > half + FOOTPRINT_TOLERANCE:
            raise FootprintError(
                f"the sleeve under the hole reaches {reach * 1e3:.2f} mm from the plate centre, "
                f"beyond the plate's {half * 1e3:g} mm half-width (hole depth "
                f"{p.hole_depth * 1e3:.1f} mm, tilts ({math.degrees(p.hole_tilt_x):.1f}, "
                f"{math.degrees(p.hole_tilt_y):.1f}) deg, hole at ({p.hole_x * 1e3:.1f}, "
                f"{p.hole_y * 1e3:.1f}) mm, circumradius {p.circumradius * 1e3:.1f} mm): reduce "
                "peg_height, hole_depth_fraction, the tilts or the hole offset"
            )
    module = body - hole
    peg = peg_mesh(p)
    return ModuleGeometry(
        params=p,
        peg=peg,
        module=_to_mesh(module),
        hole_planes=hole_planes,
        sleeve_planes=sleeve_planes,
        hole_section=np.array([section.min(axis=0), section.max(axis=0)]),
        entrance=entrance,
        bottom=bottom,
        design_pose=design,
        module_genus=int(module.genus()),
        module_volume=float(module.volume()),
        hole_chamfer_planes=chamfer,
    )


def insertion_travel(geom: ModuleGeometry) -> float:
    """How far above the design pose the checked straight insertion starts (m): enough for
    the peg's bottom face to be above the mounting surface at any tilt."""
    p = geom.params
    return p.hole_depth + p.circumradius + 0.01
