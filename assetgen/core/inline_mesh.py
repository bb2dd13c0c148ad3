"""Meshes stored inline in an MJCF file: `<mesh vertex=... face=... scale="0.001 ...">`.

A module's MJCF carries its peg and its convex collision pieces as inline mesh data, so the
file is self-contained: it loads on its own in MuJoCo's viewer or MuJoCo Warp, from any
folder. The numbers are the binary STL's own: float32 millimetres, written with 9 significant
digits (enough to round-trip any float32), vertices merged exactly as reading the STL back
merges them (assetgen.core.stl.merge_vertices). So a mesh read back from the MJCF is, array
for array, the mesh read back from the same mesh's STL, and the simulator sees the same bytes
whichever file it reads.

Hand-written because no library does this: trimesh writes no MJCF, and MuJoCo's own parser
(MjSpec) reads a whole model where the simulator needs only the meshes, at about eight
times the cost (`assetgen bench load`).
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from assetgen.core.mesh import Mesh, StoredMesh
from assetgen.core.stl import merge_vertices

MM_PER_M = 1000.0
"""The stored unit is the millimetre, as in the STL files."""
SCALE_ATTR = "0.001 0.001 0.001"
"""The `scale` every inline mesh carries: metres per stored unit."""
MJCF_FILE = "peg_in_hole.xml"
"""A module's MJCF file: it holds the peg and the collision pieces as inline meshes."""
ASSEMBLY_MJCF_FILE = "assembly.xml"
"""An assembly's MJCF file: every part's convex pieces as inline meshes `<part>_<i>`."""
PEG_MESH = "peg"
"""The peg's mesh name in a module's MJCF."""
PIECE_PREFIX = "piece_"
"""Collision piece i is the mesh (and geom) `piece_<i, three digits>`."""


def piece_name(i: int) -> str:
    """The mesh and geom name of collision piece `i` in a module's MJCF."""
    return f"{PIECE_PREFIX}{i:03d}"


def stored(meshes: Sequence[Mesh]) -> list[StoredMesh]:
    """The meshes (metres) as a float32-millimetre file stores them and a reader gets them
    back: each corner rounded to float32 mm, then identical corners merged. The same arrays
    as writing each to STL and parsing it (parse_stl_mm); idempotent: a StoredMesh comes back
    as it is, without the rounding and merging again (~0.5 ms a module)."""
    out: list[StoredMesh | None] = [m if isinstance(m, StoredMesh) else None for m in meshes]
    todo = [i for i, m in enumerate(out) if m is None]
    if todo:
        tris = [
            (meshes[i].vertices[meshes[i].faces] * MM_PER_M).astype("<f4").astype(np.float64)
            / MM_PER_M
            for i in todo
        ]
        for i, m in zip(todo, merge_vertices(tris), strict=True):
            out[i] = m
    return out  # type: ignore[return-value]


def _vertices_mm(mesh: Mesh) -> np.ndarray:
    """The float32 millimetre numbers of a stored mesh's vertices (exact: the round trip
    float32 -> /1000 -> *1000 -> float32 is the identity)."""
    return (mesh.vertices * MM_PER_M).astype(np.float32)


def mesh_element(name: str, mesh: Mesh) -> str:
    """The `<mesh>` element holding a stored mesh (see `stored`) inline; one line."""
    v = _vertices_mm(mesh).astype(np.float64).ravel()
    f = np.asarray(mesh.faces, dtype=np.int64).ravel()
    # %.9g round-trips every float32; formatting the whole array in one % is ~5x faster
    # than a Python loop over numpy scalars
    vertex = " ".join(["%.9g"] * len(v)) % tuple(v.tolist())
    face = " ".join(map(str, f.tolist()))
    return f'<mesh name="{name}" scale="{SCALE_ATTR}" vertex="{vertex}" face="{face}"/>'


def read_inline_meshes(data: bytes | str, where: str = "the MJCF") -> dict[str, Mesh]:
    """Every inline `<asset><mesh>` of an MJCF document, by name, in metres.

    Raises ValueError naming `where` and the mesh when the XML does not parse, or a mesh has
    no vertex or face data, a scale other than SCALE_ATTR, a vertex count not a multiple of 3,
    non-finite numbers, or a face index out of range.
    """
    try:
        root = ET.fromstring(data)
    except ET.ParseError as e:
        raise ValueError(f"{where}: not valid XML ({e})") from None
    names, vtexts, ftexts = [], [], []
    for el in root.iterfind("asset/mesh"):
        name = el.get("name", "?")
        vtext, ftext = el.get("vertex"), el.get("face")
        if vtext is None or ftext is None:
            raise ValueError(f"{where}: mesh {name!r} has no inline vertex and face data")
        if el.get("scale") != SCALE_ATTR and " ".join(el.get("scale", "").split()) != SCALE_ATTR:
            raise ValueError(
                f"{where}: mesh {name!r} has scale {el.get('scale')!r}; expected {SCALE_ATTR!r}"
            )
        names.append(name)
        vtexts.append(vtext)
        ftexts.append(ftext)
    arrays = _parse_all(vtexts, ftexts)
    if arrays is None:  # something is off: find it mesh by mesh, with its name
        arrays = [
            _parse_one(v, f, f"{where}: mesh {n!r}")
            for n, v, f in zip(names, vtexts, ftexts, strict=True)
        ]
    return {
        n: Mesh(v.astype(np.float64).reshape(-1, 3) / MM_PER_M, f.reshape(-1, 3))
        for n, (v, f) in zip(names, arrays, strict=True)
    }


def _parse_all(vtexts: list[str], ftexts: list[str]) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """Every mesh's numbers, parsed in two numpy calls for the whole document (a module's
    ~30 meshes one by one cost three times as much), when the data is as the writer leaves
    it: numbers separated by single spaces, counts multiples of 3, finite vertices, face
    indices in range. None when anything differs; the caller then parses mesh by mesh."""
    if not vtexts:
        return []
    vcount = np.array([t.count(" ") + 1 for t in vtexts])
    fcount = np.array([t.count(" ") + 1 for t in ftexts])
    try:  # a token it cannot read ends the parse (numpy 2.4 raises; older ones warn)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            v = np.fromstring(" ".join(vtexts), dtype=np.float32, sep=" ")
            f = np.fromstring(" ".join(ftexts), dtype=np.int64, sep=" ")
    except ValueError:
        return None
    if (
        len(v) != vcount.sum()
        or len(f) != fcount.sum()
        or (vcount % 3).any()
        or (fcount % 3).any()
        or not np.isfinite(v).all()
    ):
        return None
    vsplit, fsplit = np.cumsum(vcount)[:-1], np.cumsum(fcount)[:-1]
    fstart = np.concatenate([[0], fsplit])
    nv = vcount // 3
    if (f < 0).any() or (np.maximum.reduceat(f, fstart) >= nv).any():
        return None
    return list(zip(np.split(v, vsplit), np.split(f, fsplit), strict=True))


def _parse_one(vtext: str, ftext: str, what: str) -> tuple[np.ndarray, np.ndarray]:
    """One mesh's (vertex, face) numbers, or ValueError naming `what` and the problem."""
    try:
        v = np.array(vtext.split(), dtype=np.float32)
        f = np.array(ftext.split(), dtype=np.int64)
    except ValueError as e:
        raise ValueError(f"{what}: unreadable numbers ({e})") from None
    if len(v) % 3 or len(f) % 3 or len(f) == 0:
        raise ValueError(
            f"{what}: {len(v)} vertex and {len(f)} face numbers; both must be non-zero "
            "multiples of 3"
        )
    if not np.isfinite(v).all():
        raise ValueError(f"{what}: non-finite vertex coordinates")
    nv = len(v) // 3
    if f.min() < 0 or f.max() >= nv:
        raise ValueError(f"{what}: face index outside 0 .. {nv - 1}")
    return v, f


def module_meshes(data: bytes | str, where: str = "the MJCF") -> tuple[Mesh, tuple[Mesh, ...]]:
    """A module MJCF's peg and collision pieces (in file order), read as read_inline_meshes
    reads them; ValueError naming `where` also when the peg or every piece is missing."""
    meshes = read_inline_meshes(data, where)
    pieces = tuple(m for n, m in meshes.items() if n.startswith(PIECE_PREFIX))
    if PEG_MESH not in meshes or not pieces:
        raise ValueError(f"{where}: holds no inline peg mesh or no collision pieces")
    return meshes[PEG_MESH], pieces


def part_piece_name(part: str, i: int) -> str:
    """The mesh and geom name of convex piece `i` of `part` in an assembly's MJCF."""
    return f"{part}_{i:03d}"


def part_pieces(meshes: dict[str, Mesh], part: str) -> list[Mesh]:
    """The pieces of `part` among an assembly MJCF's inline meshes (read_inline_meshes), in
    file order."""
    return [m for name, m in meshes.items() if name.rsplit("_", 1)[0] == part]


def same_mesh(a: Mesh, b: Mesh) -> bool:
    """Equal arrays, bit for bit (what `stored` promises of a file's read-back)."""
    return (
        a.vertices.shape == b.vertices.shape
        and a.faces.shape == b.faces.shape
        and bool(np.array_equal(a.vertices, b.vertices))
        and bool(np.array_equal(a.faces, b.faces))
    )
