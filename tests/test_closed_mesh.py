"""Batched closed-solid checks and vertex merging give what the one-mesh versions give."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from assetgen.checks.closed_mesh import check_closed_meshes
from assetgen.collision.exact import exact_pieces
from assetgen.core.mesh import Mesh
from assetgen.core.stl import merge_vertices, parse_stl_mm, parse_stl_triangles_mm, stl_bytes
from assetgen.geometry.solids import build_module
from assetgen.params.sampler import SamplerConfig, sample_params


def _written_pieces(seed: int) -> list[bytes]:
    g = build_module(sample_params(SamplerConfig(), seed))
    return [stl_bytes(m) for m in exact_pieces(g)] + [stl_bytes(g.peg), stl_bytes(g.module)]


@pytest.mark.parametrize("seed", [0, 5, 13])
def test_merge_vertices_equals_parse_stl_mm(seed):
    data = _written_pieces(seed)
    merged = merge_vertices([parse_stl_triangles_mm(d) for d in data])
    for d, m in zip(data, merged, strict=True):
        one = parse_stl_mm(d)
        assert np.array_equal(one.vertices, m.vertices) and np.array_equal(one.faces, m.faces)


def _as_meshes(data: list[bytes]) -> list[Mesh]:
    return merge_vertices([parse_stl_triangles_mm(d) for d in data])


def test_written_pieces_pass():
    data = _written_pieces(3)[:-1]  # pieces and peg: convex
    check_closed_meshes(_as_meshes(data), [f"m{i}" for i in range(len(data))], convex=True)


def _dented_box() -> Mesh:
    box = trimesh.creation.box(extents=[0.01, 0.01, 0.01])
    v = box.vertices.copy()
    v[int(np.argmax(v.sum(axis=1)))] *= 0.2  # one corner pushed inwards
    return Mesh(v, np.asarray(box.faces, np.int64))


def test_a_dent_among_many_is_named():
    meshes = _as_meshes(_written_pieces(3)[:-1])
    meshes.insert(2, _dented_box())
    names = [f"m{i}" for i in range(len(meshes))]
    with pytest.raises(ValueError, match=r"m2: not convex"):
        check_closed_meshes(meshes, names, convex=True)
    check_closed_meshes(meshes, names, convex=False)  # closed, just not convex


def test_open_and_flipped_meshes_are_named():
    meshes = _as_meshes(_written_pieces(3)[:4])
    m = meshes[1]
    opened = [*meshes[:1], Mesh(m.vertices, m.faces[1:]), *meshes[2:]]
    with pytest.raises(ValueError, match=r"m1: not watertight"):
        check_closed_meshes(opened, ["m0", "m1", "m2", "m3"], convex=True)
    inside_out = [*meshes[:3], Mesh(meshes[3].vertices, meshes[3].faces[:, ::-1])]
    with pytest.raises(ValueError, match=r"m3: volume .* is not positive"):
        check_closed_meshes(inside_out, ["m0", "m1", "m2", "m3"], convex=True)
    f = meshes[2].faces.copy()
    f[0] = f[0, ::-1]
    with pytest.raises(ValueError, match=r"m2: triangles are wound inconsistently"):
        check_closed_meshes(
            [*meshes[:2], Mesh(meshes[2].vertices, f)], ["a", "b", "m2"], convex=True
        )
