"""MJCF export and MuJoCo contact settings, on a synthetic square peg-in-hole module.

The module is built here (not by the generator): a 20 x 20 x 40 mm peg, a 22 x 22 mm hole
(1 mm clearance per side) 25 mm deep, in a 150 x 150 x 5 mm plate with a sleeve of 5 mm walls
and a 5 mm floor. Its collision pieces are the exact convex decomposition "plate (or sleeve)
beyond one face plane of the hole" (each an intersection of half-spaces, hulled by trimesh),
stored inline in the MJCF. The same module is also built with its hole axis tilted (15 deg
about x, -15 deg about y, 30 deg yaw), so the drop test pushes along a non-vertical axis.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from assetgen.core.frames import Frame, matrix_to_quat
from assetgen.core.inline_mesh import read_inline_meshes, same_mesh, stored
from assetgen.core.mesh import Mesh
from assetgen.core.mujoco_config import PhysicsConfig, physics_for
from assetgen.formats.mjcf import write_mjcf
from assetgen.physics.mjcf_checks import drop_test, side_push_test

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
    """A module's meshes, the folder its MJCF goes to, and what the exporter needs."""

    folder: Path
    peg: Mesh
    pieces: list[Mesh]
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


def _mesh(tm: trimesh.Trimesh) -> Mesh:
    return Mesh(np.asarray(tm.vertices, float), np.asarray(tm.faces, np.int64))


def peg_mass_properties() -> tuple[np.ndarray, np.ndarray]:
    """COM (3,) m in the peg frame and inertia (3, 3) kg m^2 about it (uniform box)."""
    w, h = 2 * PEG_HALF, PEG_HEIGHT
    com = np.array([0.0, 0.0, h / 2])
    inertia = PEG_MASS / 12.0 * np.diag([w * w + h * h, w * w + h * h, 2 * w * w])
    return com, inertia


def make_module(folder: Path, tilt: tuple[float, float, float] = (0.0, 0.0, 0.0)):
    """The module's peg and pieces, its MJCF to go to `folder`; the hole axis is the module
    z turned by `tilt` = (about x, about y, yaw about the axis) degrees."""
    rot = _rotation(*tilt)
    entrance = np.array([*ENTRANCE_XY, 0.0])
    hole = np.eye(4)  # hole frame = bottom frame: floor centre, z out of the hole
    hole[:3, :3] = rot
    hole[:3, 3] = entrance - DEPTH * rot[:, 2]
    peg = _polytope(_box_halfspaces([-PEG_HALF] * 2 + [0.0], [PEG_HALF] * 2 + [PEG_HEIGHT]))

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
    pieces = []
    for solid in (plate, sleeve):
        for normal, offset in planes:
            n = rot @ np.asarray(normal, float)
            # beyond the plane: n . (x - origin) >= offset
            piece = _polytope([*solid, (-n, -offset - n @ hole[:3, 3])])
            if piece is None:  # nothing of this solid lies beyond the plane
                continue
            pieces.append(_mesh(piece))
    quat = tuple(float(q) for q in matrix_to_quat(rot))
    bottom = Frame(tuple(float(x) for x in hole[:3, 3]), quat)
    design = Frame(tuple(float(x) for x in hole[:3, 3] + CLEARANCE * rot[:, 2]), quat)
    return SyntheticModule(
        folder, _mesh(peg), pieces, Frame(tuple(entrance), (1.0, 0.0, 0.0, 0.0)), bottom, design
    )


def document_args(module: SyntheticModule) -> dict:
    """write_mjcf's / mjcf_document's keyword arguments for `module`."""
    com, inertia = peg_mass_properties()
    return dict(
        peg=module.peg,
        pieces=module.pieces,
        entrance=module.entrance,
        bottom=module.bottom,
        peg_pose=module.design,
        peg_mass=PEG_MASS,
        peg_com=com,
        peg_inertia=inertia,
        clearance=CLEARANCE,
    )


def export(module: SyntheticModule, contact: PhysicsConfig = PhysicsConfig(), **kw) -> Path:  # noqa: B008
    args = {**document_args(module), "contact": contact, **kw}
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
    assert m.nbody == 2 and m.njnt == 1 and m.ngeom == len(module.pieces) + 1
    assert m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert m.opt.timestep == physics_for(CLEARANCE).timestep == PhysicsConfig().timestep
    assert np.all(m.opt.gravity == 0)
    assert m.numeric("clearance").data[0] == CLEARANCE
    for name in ("entrance", "bottom", "peg_bottom", "origin"):
        m.site(name)  # raises KeyError if absent
    assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC


def test_peg_body_frame_is_the_peg_frame(module_xml) -> None:
    """MuJoCo recentres mesh geoms; the body frame (free joint qpos) must stay the peg frame."""
    module, path = module_xml
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    peg = m.body("peg").id
    pose = module.design.matrix()
    np.testing.assert_allclose(d.xpos[peg], pose[:3, 3], atol=1e-12)
    np.testing.assert_allclose(d.xmat[peg].reshape(3, 3), pose[:3, :3], atol=1e-9)
    np.testing.assert_allclose(d.qpos[:3], pose[:3, 3], atol=1e-12)
    site = m.site("peg_bottom")
    np.testing.assert_array_equal(m.site_pos[site.id], 0.0)
    np.testing.assert_allclose(d.site_xpos[site.id], pose[:3, 3], atol=1e-12)
    # the peg's collision vertices, expressed in the body frame, are the STL's: bottom face
    # at z = 0, centred on the axis
    g = m.geom("peg").id
    mesh = m.geom_dataid[g]
    start, count = m.mesh_vertadr[mesh], m.mesh_vertnum[mesh]
    world = d.geom_xpos[g] + m.mesh_vert[start : start + count] @ d.geom_xmat[g].reshape(3, 3).T
    local = (world - pose[:3, 3]) @ pose[:3, :3]
    np.testing.assert_allclose(local.min(axis=0), [-PEG_HALF, -PEG_HALF, 0.0], atol=1e-7)
    np.testing.assert_allclose(local.max(axis=0), [PEG_HALF, PEG_HALF, PEG_HEIGHT], atol=1e-7)
    # explicit inertial: mass, COM in the peg frame, inertia about it
    com, inertia = peg_mass_properties()
    assert m.body_mass[peg] == PEG_MASS
    np.testing.assert_allclose(m.body_ipos[peg], com, atol=1e-12)
    np.testing.assert_allclose(np.sort(m.body_inertia[peg]), np.sort(np.diag(inertia)), rtol=1e-9)


def test_frames_are_sites(module_xml) -> None:
    module, path = module_xml
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for name, frame in (("entrance", module.entrance), ("bottom", module.bottom)):
        site = m.site(name).id
        np.testing.assert_allclose(d.site_xpos[site], frame.pos, atol=1e-12)
        np.testing.assert_allclose(
            d.site_xmat[site].reshape(3, 3), frame.matrix()[:3, :3], atol=1e-9
        )


def test_pieces_collide_with_the_peg_only(module_xml) -> None:
    _, path = module_xml
    m = mujoco.MjModel.from_xml_path(str(path))
    peg = m.geom("peg").id
    pieces = [g for g in range(m.ngeom) if g != peg]

    def collide(a: int, b: int) -> bool:
        return bool(
            (m.geom_contype[a] & m.geom_conaffinity[b])
            or (m.geom_contype[b] & m.geom_conaffinity[a])
        )

    assert all(collide(peg, g) for g in pieces)
    assert not any(collide(a, b) for a, b in itertools.combinations(pieces, 2))


def test_drop_reaches_the_floor(module_xml) -> None:
    """Pushed down the hole axis (weight + 5 N, along a tilted axis too), the peg comes to
    rest with its frame on the bottom frame, penetrating the floor far less than 0.1 mm."""
    _, path = module_xml
    r = drop_test(path)
    print({k: v for k, v in r.items()})
    assert r["reached_floor"] and r["settled"]
    assert r["rest_distance"] < 0.2e-3
    assert r["max_penetration"] < 0.1e-3
    assert r["lateral_offset"] < 0.1e-3 and r["tilt"] < 1e-3


def test_side_push_comes_to_rest(module_xml) -> None:
    """Pushed with a constant 5 N into every wall, the peg comes to rest (the 5 ms physics
    of version 1 left it bouncing in a limit cycle: docs/physics.md)."""
    _, path = module_xml
    assert side_push_test(path, force=5.0, directions=8)["settled"]


def test_side_push_stops_at_the_walls(module_xml) -> None:
    """A 5 N push across the axis moves the peg by the clearance towards a face (the free
    travel, sqrt(2) x the clearance into a corner) and no further than 0.1 mm beyond it."""
    _, path = module_xml
    r = side_push_test(path, force=5.0, directions=8)
    print({k: v for k, v in r.items() if not isinstance(v, list)})
    assert not r["passed_through"]
    free = np.array(r["free_travel"])
    expected = np.where(np.arange(8) % 2 == 0, CLEARANCE, math.sqrt(2) * CLEARANCE)
    np.testing.assert_allclose(free, expected, atol=5e-6)  # float32 STL, distance tolerance
    assert np.all(np.array(r["lateral"]) <= free + 0.1e-3)  # every step, not only at rest
    assert r["max_overshoot"] < 0.1e-3
    assert r["max_penetration"] < 0.1e-3 and r["max_penetration_at_rest"] < 0.1e-3


def test_side_push_at_mid_depth_with_the_peg_pressed_down(module_xml) -> None:
    _, path = module_xml
    r = side_push_test(path, insertion=0.5, axial_force=2.0, directions=4)
    assert r["settled"] and not r["passed_through"]
    assert r["max_overshoot"] < 0.1e-3 and r["max_penetration_at_rest"] < 0.1e-3


def test_unguarded_push_and_fall_are_still_stopped(module_xml) -> None:
    """Without the speed guard a 5 N push hits the wall at ~0.2 m/s and the fall lands at
    ~1 m/s: at 200 Hz the peg is up to a step's travel inside the surface before the contact
    acts (the transient, printed), yet the walls and the floor stop it and it comes back."""
    _, path = module_xml
    push = side_push_test(path, speed=None, directions=4)
    fall = drop_test(path, speed=None)
    print("transients:", push["max_penetration"], fall["max_penetration_transient"])
    assert push["settled"] and not push["passed_through"]
    assert push["max_penetration_at_rest"] < 0.1e-3 and push["max_overshoot"] < 0.1e-3
    assert fall["reached_floor"] and fall["max_penetration"] < 0.1e-3


def test_mujoco_default_contacts_sink_too_far(tmp_path) -> None:
    """Why the contacts (assetgen.core.mujoco_config.PhysicsConfig) are tuned: MuJoCo's
    default softness lets the peg sink into the floor by a good part of the clearance
    (0.34 mm under implicitfast without actuators, 0.19 mm under the training physics'
    discrete integrator and damper), the defaults by micrometres."""
    module = make_module(tmp_path)
    soft = PhysicsConfig(contact_timeconst=0.02, solimp=(0.9, 0.95, 0.001, 0.5, 2.0))
    assert drop_test(export(module, soft))["max_penetration"] > 0.15e-3
    assert drop_test(export(module))["max_penetration"] < 0.05e-3


# ---------------------------------------------------------------------------------------------
# bad input: a ValueError naming the file and the problem, and nothing written
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def good_module(tmp_path_factory) -> SyntheticModule:
    return make_module(tmp_path_factory.mktemp("good"))


def _copy(module: SyntheticModule, folder: Path) -> SyntheticModule:
    folder.mkdir(parents=True)
    return replace(module, folder=folder)


def _assert_nothing_written(module: SyntheticModule, before: bytes | None = None) -> None:
    xml = module.folder / "peg_in_hole.xml"
    if before is None:
        assert not xml.exists()
    else:
        assert xml.read_bytes() == before
    assert not list(module.folder.glob(".*tmp*")), "a temporary file was left behind"


def test_bad_mesh_keeps_the_previous_file(good_module, tmp_path) -> None:
    module = _copy(good_module, tmp_path / "m")
    before = export(module).read_bytes()
    pieces = list(module.pieces)
    v = pieces[0].vertices.copy()
    v[0, 2] = np.nan
    pieces[0] = Mesh(v, pieces[0].faces)
    with pytest.raises(ValueError, match=r"mesh 'piece_000' needs finite"):
        export(module, pieces=pieces)
    _assert_nothing_written(module, before)


def test_open_piece(good_module, tmp_path) -> None:
    module = _copy(good_module, tmp_path / "m")
    pieces = list(module.pieces)
    pieces[1] = Mesh(pieces[1].vertices, pieces[1].faces[1:])  # one triangle less
    with pytest.raises(ValueError, match=r"piece_001: not watertight"):
        export(module, pieces=pieces)
    _assert_nothing_written(module)


def _dented_box() -> Mesh:
    """A closed, consistently wound box with one corner pushed inwards: not convex."""
    box = trimesh.creation.box(extents=[0.01, 0.01, 0.01])
    v = box.vertices.copy()
    corner = int(np.argmax(v.sum(axis=1)))  # the (+, +, +) corner
    v[corner] *= 0.2  # inside the plane of its three neighbours
    return Mesh(v, np.asarray(box.faces, np.int64))


@pytest.mark.parametrize("which", ["piece_002", "peg"])
def test_non_convex_mesh(good_module, tmp_path, which: str) -> None:
    module = _copy(good_module, tmp_path / "m")
    if which == "peg":
        kw = {"peg": _dented_box()}
    else:
        kw = {"pieces": [*module.pieces[:2], _dented_box(), *module.pieces[3:]]}
    with pytest.raises(ValueError, match=rf"{which}: not convex"):
        export(module, **kw)
    _assert_nothing_written(module)


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"peg_mass": 0.0}, "peg_mass"),
        ({"peg_inertia": np.diag([1e-6, 1e-6, 5e-6])}, "triangle inequality"),
        ({"peg_com": np.array([0.0, np.nan, 0.0])}, "peg_com"),
        ({"bottom": Frame((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0))}, "bottom.quat"),
        ({"clearance": -0.001}, "clearance"),
        ({"pieces": []}, "pieces is empty"),
        (
            {"contact": PhysicsConfig(integrator="implicitfast", contact_timeconst=0.0008)},
            "below twice the timestep",
        ),
    ],
)
def test_bad_values(good_module, tmp_path, kw: dict, message: str) -> None:
    module = _copy(good_module, tmp_path / "m")
    with pytest.raises(ValueError, match=message):
        export(module, **kw)
    _assert_nothing_written(module)


def test_same_input_same_bytes(good_module, tmp_path) -> None:
    a = export(_copy(good_module, tmp_path / "a")).read_bytes()
    b = export(_copy(good_module, tmp_path / "b")).read_bytes()
    assert a == b


def test_model_mujoco_refuses_is_named_and_not_written(good_module, tmp_path, monkeypatch) -> None:
    import assetgen.formats.mjcf as mjcf_export

    module = _copy(good_module, tmp_path / "m")
    text = mjcf_export.mjcf_text
    # A document our checks pass but MuJoCo's compiler does not: a geom naming no mesh.
    monkeypatch.setattr(
        mjcf_export,
        "mjcf_text",
        lambda **kw: text(**kw).replace('mesh="piece_000"/>', 'mesh="no_such_mesh"/>'),
    )
    with pytest.raises(ValueError, match=r"peg_in_hole\.xml: MuJoCo refuses the model"):
        export(module)
    _assert_nothing_written(module)


def test_the_file_holds_the_stored_meshes_and_loads_anywhere(good_module, tmp_path) -> None:
    """The inline meshes read back as the float32-millimetre meshes (what STL files of them
    read back as), and the file loads alone from another folder."""
    module = _copy(good_module, tmp_path / "m")
    path = export(module)
    back = read_inline_meshes(path.read_bytes())
    want = stored([module.peg, *module.pieces])
    assert list(back) == ["peg", *(f"piece_{i:03d}" for i in range(len(module.pieces)))]
    assert all(same_mesh(b, w) for b, w in zip(back.values(), want, strict=True))
    other = tmp_path / "elsewhere"
    other.mkdir()
    moved = other / "any_name.xml"
    path.rename(moved)
    assert mujoco.MjModel.from_xml_path(str(moved)).nmesh == len(module.pieces) + 1
