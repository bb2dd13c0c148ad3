"""The profile-bolt family's geometry: each step's part at exactly its clearance from
everything present, its straight path clear, and bad parameters named."""

from __future__ import annotations

from dataclasses import replace

import fcl
import manifold3d as m3
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from assetgen.checks.module_checks import CheckError
from assetgen.checks.step_checks import check_parts, check_steps
from assetgen.collision.carve import carve_part
from assetgen.core.inline_mesh import stored
from assetgen.core.mesh import Mesh, cross3
from assetgen.core.stl import parse_stl_mm, stl_bytes
from assetgen.families.part_mesh import part_mesh
from assetgen.families.profile_bolt import ProfileBoltParams, ProfileBoltSampler, build_profile_bolt
from assetgen.params.module_params import ParamError

TOL = 1e-7
"""m: the gaps are exact up to float rounding (before any file stores them)."""


def posed(mesh: Mesh, pose: np.ndarray) -> Mesh:
    return mesh.transformed(pose)


def convex(vertices: np.ndarray) -> fcl.CollisionObject:
    hull = ConvexHull(vertices)
    faces = np.column_stack([np.full(len(hull.simplices), 3), hull.simplices]).ravel()
    return fcl.CollisionObject(fcl.Convex(vertices, len(hull.simplices), faces))


def gap(a: list[np.ndarray], b: list[np.ndarray]) -> float:
    """Smallest distance between two sets of convex point clouds (their hulls)."""
    oa, ob = [convex(v) for v in a], [convex(v) for v in b]
    return min(
        fcl.distance(x, y, fcl.DistanceRequest(), fcl.DistanceResult()) for x in oa for y in ob
    )


def pieces_in_module(part) -> list[Mesh]:
    return [posed(m, part.pose) for m in carve_part(part.solids, part.holes)]


def volume(mesh: Mesh) -> float:
    t = mesh.vertices[mesh.faces]
    return float(np.einsum("ij,ij->i", t[:, 0], cross3(t[:, 1], t[:, 2])).sum() / 6.0)


def check_geometry(params: ProfileBoltParams) -> None:
    asm = build_profile_bolt(params)
    pieces = {p.name: pieces_in_module(p) for p in (asm.base, *asm.parts)}
    for k, step in enumerate(asm.steps):
        moving = [m.vertices for m in pieces[step.part]]
        present = [m.vertices for p in asm.present_at(k) for m in pieces[p.name]]
        seated = gap(moving, present)
        assert seated == pytest.approx(step.clearance, abs=TOL), step.part
        # the straight path: each convex piece swept from `travel` up the axis to its seat
        axis = _axis(step)
        swept = [np.vstack([v, v + step.travel * axis]) for v in moving]
        assert gap(swept, present) >= step.clearance - TOL, step.part


def _axis(step) -> np.ndarray:
    from assetgen.core.rotations import quat_to_matrix

    return quat_to_matrix(np.asarray(step.bottom.quat))[:, 2]


@pytest.mark.parametrize("slots", [False, True])
def test_both_steps_sit_at_their_clearances(slots) -> None:
    check_geometry(replace(ProfileBoltSampler().sample(3), slots=slots))


@pytest.mark.parametrize("seed", range(4))
def test_sampled_assemblies(seed) -> None:
    check_geometry(ProfileBoltSampler().sample(seed))


def test_the_base_pieces_make_up_the_block_and_plate() -> None:
    """Without overlap, the base's pieces add up to plate + block minus the socket and the
    bolt's holes (plate and block share only a face); with it, their union is that solid
    and their volumes add up to more."""
    asm = build_profile_bolt(replace(ProfileBoltSampler().sample(1), slots=True))
    tiles = carve_part(asm.base.solids, asm.base.holes, overlap=0.0)
    pieces = carve_part(asm.base.solids, asm.base.holes)

    def solid(planes) -> m3.Manifold:
        (m,) = carve_part([planes], [])
        return m3.Manifold(m3.Mesh(vert_properties=m.vertices, tri_verts=m.faces.astype(np.uint32)))

    body = m3.Manifold.batch_boolean([solid(s) for s in asm.base.solids], m3.OpType.Add)
    # the holes reach far up their axes: clip them to a big box first
    big = np.vstack(
        [
            np.column_stack([np.eye(3), np.full(3, 0.3)]),
            np.column_stack([-np.eye(3), np.full(3, 0.3)]),
        ]
    )
    holes = m3.Manifold.batch_boolean(
        [solid(np.vstack([h, big])) for h in asm.base.holes], m3.OpType.Add
    )
    base = body - holes
    assert sum(volume(m) for m in tiles) == pytest.approx(base.volume(), rel=1e-6)
    union = m3.Manifold.batch_boolean(
        [
            m3.Manifold(m3.Mesh(vert_properties=m.vertices, tri_verts=m.faces.astype(np.uint32)))
            for m in pieces
        ],
        m3.OpType.Add,
    )
    assert union.volume() == pytest.approx(base.volume(), rel=1e-6)
    assert (union + base).volume() == pytest.approx(base.volume(), rel=1e-6)
    assert sum(volume(m) for m in pieces) > base.volume() * 1.01


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"bolt_diameter": 0.008, "profile_side": 0.015, "bolt_clearance": 0.003}, "bolt_diameter"),
        ({"profile_length": 0.05, "insertion_depth": 0.048}, "insertion_depth"),
        ({"profile_clearance": 0.0}, "profile_clearance"),
        ({"bolt_clearance": -1e-4}, "bolt_clearance"),
        ({"profile_side": 0.05}, "profile_side"),
    ],
)
def test_parameters_that_collide_are_named(change, named) -> None:
    good = ProfileBoltSampler().sample(0)
    with pytest.raises(ParamError, match=named):
        replace(good, **change).validate()


def test_the_sampler_always_builds() -> None:
    for seed in range(200):
        ProfileBoltSampler().sample(seed).validate()


def stored_parts(asm):
    """Each part's surface and pieces as the files store them (float32 mm STL)."""
    meshes = {p.name: parse_stl_mm(stl_bytes(part_mesh(p)), p.name) for p in (asm.base, *asm.parts)}
    pieces = {p.name: stored(carve_part(p.solids, p.holes)) for p in asm.parts}
    return meshes, pieces


@pytest.mark.parametrize("slots", [False, True])
def test_the_stored_files_pass_the_step_checks(slots) -> None:
    """On the STL files as written: every part one closed body (the profile with its cross
    hole has genus 1), and each step's part at its clearance within 1 um, path clear."""
    asm = build_profile_bolt(replace(ProfileBoltSampler().sample(5), slots=slots))
    meshes, pieces = stored_parts(asm)
    parts = check_parts(meshes)
    assert parts["profile"]["genus"] == 1 and parts["bolt"]["genus"] == 0
    steps = check_steps(asm, meshes, pieces)
    assert [s["part"] for s in steps] == ["profile", "bolt"]
    for s, step in zip(steps, asm.steps, strict=True):
        assert s["clearance_m"] == pytest.approx(step.clearance, abs=1e-6)


def test_a_profile_hole_too_tight_is_refused() -> None:
    """The checks measure the files: a socket cut for a tighter clearance than the step
    claims is refused, naming the step."""
    asm = build_profile_bolt(ProfileBoltSampler().sample(5))
    meshes, pieces = stored_parts(asm)
    wrong = replace(asm, steps=(replace(asm.steps[0], clearance=0.3e-3), asm.steps[1]))
    with pytest.raises(CheckError, match=r"step 1 \(profile\): seated 0\.25"):
        check_steps(wrong, meshes, pieces)
    longer = replace(asm, steps=(asm.steps[0], replace(asm.steps[1], travel=1.0)))
    check_steps(longer, meshes, pieces)  # a longer straight path is still clear...
    sideways = replace(asm.steps[1], bottom=asm.steps[0].bottom)  # ...but not along z
    with pytest.raises(CheckError, match=r"step 2 \(bolt\): its straight path"):
        check_steps(replace(asm, steps=(asm.steps[0], sideways)), meshes, pieces)
