"""Inline MJCF meshes: the STL's own numbers, read back bit for bit; bad data named."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from assetgen.core.inline_mesh import mesh_element, read_inline_meshes, same_mesh, stored
from assetgen.core.mesh import Mesh, StoredMesh
from assetgen.core.stl import parse_stl_mm, stl_bytes


def _box(lo, hi) -> Mesh:
    """An axis-aligned box, outward winding."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = np.array(
        [[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], dtype=np.float64
    )
    f = [
        [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
        [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
    ]  # fmt: skip
    return Mesh(v, np.array(f, dtype=np.int64))


def _document(meshes: dict[str, Mesh]) -> str:
    body = "".join(mesh_element(n, m) for n, m in meshes.items())
    return f"<mujoco><asset>{body}</asset></mujoco>"


coords = st.floats(-0.2, 0.2, allow_nan=False, width=64)


@settings(max_examples=60, deadline=None)
@given(lo=st.tuples(coords, coords, coords), size=st.tuples(*[st.floats(1e-4, 0.1)] * 3))
def test_a_mesh_reads_back_as_its_stl_does(lo, size) -> None:
    """Any box: the MJCF's read-back equals the STL's (float32 mm, merged the same way), and
    storing is idempotent."""
    box = _box(lo, tuple(a + s for a, s in zip(lo, size, strict=True)))
    (mesh,) = stored([box])
    via_stl = parse_stl_mm(stl_bytes(box))
    assert same_mesh(mesh, via_stl)
    back = read_inline_meshes(_document({"m": mesh}))["m"]
    assert same_mesh(back, mesh)
    assert same_mesh(stored([back])[0], mesh)


def test_a_stored_mesh_is_passed_through_and_a_moved_one_is_not() -> None:
    """stored() keeps a StoredMesh (its type says it is rounded and merged already) and
    rounds anything else, including a stored mesh moved to another frame."""
    box = _box((0.0, 0.0, 0.0), (0.01, 0.02, 1 / 30))
    (s,) = stored([box])
    assert isinstance(s, StoredMesh) and isinstance(parse_stl_mm(stl_bytes(box)), StoredMesh)
    mixed = stored([s, box])
    assert mixed[0] is s and mixed[1] is not box and same_mesh(mixed[1], s)
    shift = np.eye(4)
    shift[:3, 3] = 1e-4 / 3
    moved = s.transformed(shift)
    assert not isinstance(moved, StoredMesh)
    again = stored([moved])[0]
    assert not np.array_equal(again.vertices, moved.vertices)  # rounded to float32 mm


def test_float32_digits_survive_the_text() -> None:
    """Coordinates whose float32 needs all 9 significant digits (and -0.0) come back exact."""
    v = np.array([[0.1, -0.0, 1 / 3], [0.123456789, 7e-9, -0.075]]) * 1.0
    mesh = Mesh(np.vstack([v, v + 0.01]), np.array([[0, 1, 2], [1, 2, 3]]))
    (s,) = stored([mesh])
    back = read_inline_meshes(_document({"m": s}))["m"]
    assert np.array_equal(back.vertices, s.vertices)
    assert np.array_equal(np.signbit(back.vertices), np.signbit(s.vertices))
    # and the numbers are the float32 millimetres, not the float64 metres
    assert not np.array_equal(s.vertices, np.unique(mesh.vertices, axis=0))


BAD = {
    "not xml": ("<mujoco><asset>", r"not valid XML"),
    "no data": ('<mesh name="m" file="m.stl"/>', r"mesh 'm' has no inline vertex"),
    "metres": (
        '<mesh name="m" scale="1 1 1" vertex="0 0 0 1 0 0 0 1 0" face="0 1 2"/>',
        r"mesh 'm' has scale '1 1 1'",
    ),
    "words": (
        '<mesh name="m" scale="0.001 0.001 0.001" vertex="0 0 x 1 0 0 0 1 0" face="0 1 2"/>',
        r"mesh 'm': unreadable numbers",
    ),
    "ragged": (
        '<mesh name="m" scale="0.001 0.001 0.001" vertex="0 0 0 1 0 0 0 1" face="0 1 2"/>',
        r"mesh 'm': 8 vertex and 3 face numbers",
    ),
    "nan": (
        '<mesh name="m" scale="0.001 0.001 0.001" vertex="0 0 nan 1 0 0 0 1 0" face="0 1 2"/>',
        r"mesh 'm': non-finite",
    ),
    "index": (
        '<mesh name="m" scale="0.001 0.001 0.001" vertex="0 0 0 1 0 0 0 1 0" face="0 1 3"/>',
        r"mesh 'm': face index outside 0 \.\. 2",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_inline_meshes_are_named(case: str) -> None:
    element, message = BAD[case]
    text = element if case == "not xml" else f"<mujoco><asset>{element}</asset></mujoco>"
    with pytest.raises(ValueError, match=r"mod\.xml.*" + message):
        read_inline_meshes(text, "mod.xml")


def test_several_meshes_read_alike_however_the_numbers_are_spaced() -> None:
    """The whole-document parse (numbers as the writer spaces them) and the mesh-by-mesh
    parse (any whitespace, e.g. a file re-indented by hand) give the same arrays; a bad
    second mesh is still named."""
    boxes = [
        _box((0, 0, 0), (0.01, 0.02, 0.03)),
        _box((-0.05, 0.1, 0.0), (0.0, 0.125, 0.001)),
        _box((0.1, 0.1, 0.1), (0.2, 0.2, 0.2)),
    ]
    meshes = dict(zip("abc", stored(boxes), strict=True))
    text = _document(meshes)
    respaced = text.replace('vertex="', 'vertex="\n  ').replace(" ", "  ")
    respaced = respaced.replace("<mesh  ", "<mesh ").replace('"  ', '" ')
    assert respaced != text
    for doc in (text, respaced):
        back = read_inline_meshes(doc)
        assert list(back) == list("abc")
        assert all(same_mesh(back[k], meshes[k]) for k in "abc")
    head, tail = text.split('<mesh name="b"')
    broken = head + '<mesh name="b"' + tail.replace('face="', 'face="0 1 99 ', 1)
    with pytest.raises(ValueError, match=r"mesh 'b': face index outside"):
        read_inline_meshes(broken)
