"""The compiled mesh checks (topology's edge graph, the convexity proof by own planes) give
exactly what their numpy forms gave, on written modules and on planted bad meshes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from assetgen.checks.closed_mesh import CONVEX_TOLERANCE, MIN_PLANE_ALTITUDE, _convex_by_own_planes
from assetgen.checks.module_checks import topology
from assetgen.collision.exact import exact_pieces
from assetgen.core.mesh import Mesh, cross3
from assetgen.core.stl import merge_vertices, parse_stl_mm, parse_stl_triangles_mm, stl_bytes
from assetgen.geometry.solids import build_module
from assetgen.params.sampler import SamplerConfig, sample_params


def _topology_numpy(mesh: Mesh) -> dict:
    """topology() as numpy and scipy computed it (the reference)."""
    f = mesh.faces
    n = len(mesh.vertices)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = directed[:, 0].astype(np.int64) * n + directed[:, 1]
    rev = directed[:, 1].astype(np.int64) * n + directed[:, 0]
    unique_directed = len(np.unique(key)) == len(key)
    watertight = unique_directed and np.isin(rev, key).all()
    pair = np.sort(directed, axis=1).astype(np.int64)
    edge_key = np.unique(pair[:, 0] * n + pair[:, 1])
    undirected = np.column_stack(np.divmod(edge_key, n))
    used = np.unique(f)
    graph = coo_matrix(
        (np.ones(len(undirected)), (undirected[:, 0], undirected[:, 1])), shape=(n, n)
    )
    bodies = len(np.unique(connected_components(graph, directed=False)[1][used]))
    tri = mesh.vertices[f]
    volume = np.einsum("ij,ij->i", tri[:, 0], cross3(tri[:, 1], tri[:, 2])).sum() / 6.0
    return {
        "watertight": bool(watertight),
        "winding_consistent": bool(unique_directed),
        "bodies": int(bodies),
        "genus": int((2 * bodies - (len(used) - len(undirected) + len(f))) // 2),
        "volume_m3": float(volume),
        "triangles": len(f),
    }


def _proof_numpy(meshes: list[Mesh]) -> np.ndarray:
    """_convex_by_own_planes as numpy pairs (the reference)."""
    out = []
    t = CONVEX_TOLERANCE / 2
    for m in meshes:
        tri = m.vertices[m.faces]
        normal = cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area2 = np.linalg.norm(normal, axis=1)
        longest = np.sqrt(np.max(((tri - np.roll(tri, 1, axis=1)) ** 2).sum(axis=2), axis=1))
        good = area2 >= MIN_PLANE_ALTITUDE * np.maximum(longest, 1e-300)
        if not good.any():
            out.append(False)
            continue
        n = normal[good] / area2[good, None]
        d = np.einsum("ij,ij->i", n, tri[good, 0])
        highest = (m.vertices @ n.T - d).max(axis=1)
        out.append(bool(((highest <= t) & (highest >= -t)).all()))
    return np.array(out)


def _batched_proof(meshes: list[Mesh]) -> np.ndarray:
    nf = [len(m.faces) for m in meshes]
    voff = np.concatenate([[0], np.cumsum([len(m.vertices) for m in meshes])])
    vertices = np.vstack([m.vertices for m in meshes])
    faces = np.vstack([m.faces + o for m, o in zip(meshes, voff, strict=False)])
    owner = np.repeat(np.arange(len(meshes)), nf)
    return _convex_by_own_planes(vertices, faces, owner, voff)


def _written(seed: int) -> tuple[list[Mesh], Mesh, Mesh]:
    g = build_module(sample_params(SamplerConfig(), seed))
    pieces = merge_vertices([parse_stl_triangles_mm(stl_bytes(m)) for m in exact_pieces(g)])
    return pieces, parse_stl_mm(stl_bytes(g.peg)), parse_stl_mm(stl_bytes(g.module))


def _box(extents, shift=(0.0, 0.0, 0.0)) -> Mesh:
    b = trimesh.creation.box(extents=extents)
    return Mesh(np.asarray(b.vertices) + shift, np.asarray(b.faces, np.int64))


def _planted() -> list[Mesh]:
    """Meshes each numpy check flagged in its own way: open, flipped, two bodies, genus 1,
    unused vertices."""
    box = _box([0.01, 0.02, 0.03])
    two = _box([0.01, 0.01, 0.01], (0.05, 0.0, 0.0))
    torus = trimesh.creation.torus(major_radius=0.03, minor_radius=0.01)
    flipped = box.faces.copy()
    flipped[3] = flipped[3, ::-1]
    spare = np.vstack([box.vertices, [[1.0, 1.0, 1.0]]])
    return [
        box,
        Mesh(box.vertices, box.faces[1:]),
        Mesh(box.vertices, flipped),
        Mesh(box.vertices, np.vstack([box.faces, box.faces[:1]])),
        Mesh(np.vstack([box.vertices, two.vertices]), np.vstack([box.faces, two.faces + 8])),
        Mesh(np.asarray(torus.vertices), np.asarray(torus.faces, np.int64)),
        Mesh(spare, box.faces),
    ]


@pytest.mark.parametrize("seed", [0, 3, 7, 21])
def test_topology_equals_the_numpy_form_on_written_modules(seed):
    pieces, peg, module = _written(seed)
    for m in [peg, module, *pieces]:
        assert topology(m) == _topology_numpy(m)


def test_topology_equals_the_numpy_form_on_planted_meshes():
    got = [topology(m) for m in _planted()]
    assert got == [_topology_numpy(m) for m in _planted()]
    # and the planted meshes are what they were planted as
    assert [(t["watertight"], t["winding_consistent"]) for t in got[:4]] == [
        (True, True),
        (False, True),
        (False, False),
        (False, False),
    ]
    assert got[4]["bodies"] == 2 and got[5]["genus"] == 1 and got[6]["genus"] == 0


@pytest.mark.parametrize("seed", [0, 3, 7, 21])
def test_convexity_proof_equals_the_numpy_form(seed):
    pieces, peg, _ = _written(seed)
    meshes = [peg, *pieces]
    # dents planted in copies of the pieces: deeper than the tolerance, within it, and at
    # a tenth of it, pushed towards the piece's centre
    for depth in (10 * CONVEX_TOLERANCE, 0.4 * CONVEX_TOLERANCE, 0.1 * CONVEX_TOLERANCE):
        for p in pieces[:6]:
            v = p.vertices.copy()
            centre = v.mean(axis=0)
            v[0] += depth * (centre - v[0]) / np.linalg.norm(centre - v[0])
            meshes.append(Mesh(v, p.faces))
    dented = _box([0.01, 0.01, 0.01])
    corner = int(np.argmax(dented.vertices.sum(axis=1)))
    dented.vertices[corner] *= 0.2  # a corner pushed inwards: a dent of millimetres
    meshes.append(dented)
    got = _batched_proof(meshes)
    assert np.array_equal(got, _proof_numpy(meshes))
    assert got[: 1 + len(pieces)].all()  # written pieces are proven convex
    assert not got[-1]  # the dent is not
