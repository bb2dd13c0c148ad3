"""MJCF export and MuJoCo contact settings, on a synthetic square peg-in-hole module.

The module is built here (not by the generator): a 20 x 20 x 40 mm peg, a 22 x 22 mm hole
(1 mm clearance per side) 25 mm deep, in a 150 x 150 x 5 mm plate with a sleeve of 5 mm walls
and a 5 mm floor. Its collision pieces are the exact convex decomposition "plate (or sleeve)
beyond one face plane of the hole", cut with trimesh, written as millimetre STL.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from assetgen.frames import Frame, matrix_to_quat
from assetgen.mjcf_export import ContactConfig, write_mjcf

PEG_HALF = 0.010  # m, half-width of the square peg
PEG_HEIGHT = 0.040
CLEARANCE = 0.001
DEPTH = 0.025  # hole depth along its axis, entrance to floor
WALL = 0.005  # sleeve wall and floor thickness, and plate thickness
PLATE_HALF = 0.075
PEG_MASS = 0.2
ENTRANCE_XY = (0.010, -0.005)  # hole position on the plate, m


@dataclass(frozen=True)
class SyntheticModule:
    """A written module folder and what the exporter needs to know about it."""

    folder: Path
    piece_files: list[str]
    entrance: Frame
    bottom: Frame
    design: Frame


def _rotation(tilt_x_deg: float, tilt_y_deg: float, yaw_deg: float) -> np.ndarray:
    ax, ay, az = (math.radians(a) for a in (tilt_x_deg, tilt_y_deg, yaw_deg))
    rx = trimesh.transformations.rotation_matrix(ax, [1, 0, 0])[:3, :3]
    ry = trimesh.transformations.rotation_matrix(ay, [0, 1, 0])[:3, :3]
    rz = trimesh.transformations.rotation_matrix(az, [0, 0, 1])[:3, :3]
    return rx @ ry @ rz


def _box_halfspaces(lo, hi, transform: np.ndarray | None = None) -> list[tuple]:
    """The 6 halfspaces a . x <= b of an axis-aligned box [lo, hi] moved by `transform`."""
    t = np.eye(4) if transform is None else transform
    out = []
    for k in range(3):
        for sign, bound in ((1.0, hi[k]), (-1.0, lo[k])):
            n = sign * t[:3, k]  # outward normal
            out.append((n, sign * bound + n @ t[:3, 3]))
    return out


def _polytope(halfspaces: list[tuple]) -> trimesh.Trimesh | None:
    """Convex solid {x : a . x <= b for all (a, b)} (None if it has no volume): vertices from
    every triple of planes, hull by qhull (watertight, outward normals)."""
    a = np.array([h[0] for h in halfspaces], float)
    b = np.array([h[1] for h in halfspaces], float)
    points = []
    for i, j, k in itertools.combinations(range(len(a)), 3):
        m = a[[i, j, k]]
        if abs(np.linalg.det(m)) < 1e-12:
            continue
        x = np.linalg.solve(m, b[[i, j, k]])
        if np.all(a @ x <= b + 1e-12):
            points.append(x)
    if len(points) < 4:
        return None
    hull = trimesh.convex.convex_hull(np.array(points))
    return hull if hull.volume > 1e-9 else None


def _write_stl(mesh: trimesh.Trimesh, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    mm = mesh.copy()
    mm.apply_scale(1000.0)
    path.write_bytes(mm.export(file_type="stl"))


def peg_mass_properties() -> tuple[np.ndarray, np.ndarray]:
    """COM (3,) m in the peg frame and inertia (3, 3) kg m^2 about it (uniform box)."""
    w, h = 2 * PEG_HALF, PEG_HEIGHT
    com = np.array([0.0, 0.0, h / 2])
    inertia = PEG_MASS / 12.0 * np.diag([w * w + h * h, w * w + h * h, 2 * w * w])
    return com, inertia


def make_module(folder: Path, tilt: tuple[float, float, float] = (0.0, 0.0, 0.0)):
    """Write peg.stl and collision/piece_XXX.stl (mm) to `folder`; the hole axis is the module
    z turned by `tilt` = (about x, about y, yaw about the axis) degrees."""
    rot = _rotation(*tilt)
    entrance = np.array([*ENTRANCE_XY, 0.0])
    hole = np.eye(4)  # hole frame = bottom frame: floor centre, z out of the hole
    hole[:3, :3] = rot
    hole[:3, 3] = entrance - DEPTH * rot[:, 2]
    peg = _polytope(_box_halfspaces([-PEG_HALF] * 2 + [0.0], [PEG_HALF] * 2 + [PEG_HEIGHT]))
    _write_stl(peg, folder / "peg.stl")

    a = PEG_HALF + CLEARANCE
    plate = _box_halfspaces([-PLATE_HALF, -PLATE_HALF, -WALL], [PLATE_HALF, PLATE_HALF, 0.0])
    # the sleeve reaches well above the plate's top and is cut there (z <= 0)
    sleeve = _box_halfspaces(
        [-a - WALL, -a - WALL, -WALL], [a + WALL, a + WALL, DEPTH + 0.03], hole
    )
    sleeve.append((np.array([0.0, 0.0, 1.0]), 0.0))
    # the hole's face planes in the hole frame (outward normal, offset): the module is the
    # union of "solid beyond one plane" over the planes, each piece convex
    planes = [((1, 0, 0), a), ((-1, 0, 0), a), ((0, 1, 0), a), ((0, -1, 0), a), ((0, 0, -1), 0)]
    files = []
    for solid in (plate, sleeve):
        for normal, offset in planes:
            n = rot @ np.asarray(normal, float)
            # beyond the plane: n . (x - origin) >= offset
            piece = _polytope([*solid, (-n, -offset - n @ hole[:3, 3])])
            if piece is None:  # nothing of this solid lies beyond the plane
                continue
            name = f"collision/piece_{len(files):03d}.stl"
            _write_stl(piece, folder / name)
            files.append(name)
    quat = tuple(float(q) for q in matrix_to_quat(rot))
    bottom = Frame(tuple(float(x) for x in hole[:3, 3]), quat)
    design = Frame(tuple(float(x) for x in hole[:3, 3] + CLEARANCE * rot[:, 2]), quat)
    return SyntheticModule(
        folder, files, Frame(tuple(entrance), (1.0, 0.0, 0.0, 0.0)), bottom, design
    )


def export(module: SyntheticModule, contact: ContactConfig = ContactConfig(), **kw) -> Path:  # noqa: B008
    com, inertia = peg_mass_properties()
    args = dict(
        peg_file="peg.stl",
        piece_files=module.piece_files,
        entrance=module.entrance,
        bottom=module.bottom,
        peg_pose=module.design,
        peg_mass=PEG_MASS,
        peg_com=com,
        peg_inertia=inertia,
        clearance=CLEARANCE,
        contact=contact,
    )
    args.update(kw)
    path = module.folder / "peg_in_hole.xml"
    write_mjcf(path, **args)
    return path


TILTS = {"upright": (0.0, 0.0, 0.0), "tilted": (15.0, -15.0, 30.0)}


@pytest.fixture(scope="module", params=list(TILTS))
def module_xml(request, tmp_path_factory) -> tuple[SyntheticModule, Path]:
    module = make_module(tmp_path_factory.mktemp(request.param), TILTS[request.param])
    return module, export(module)


def test_loads_alone(module_xml) -> None:
    module, path = module_xml
    m = mujoco.MjModel.from_xml_path(str(path))
    assert m.nbody == 2 and m.njnt == 1 and m.ngeom == len(module.piece_files) + 1
    assert m.opt.timestep == 0.005
    assert np.all(m.opt.gravity == 0)
