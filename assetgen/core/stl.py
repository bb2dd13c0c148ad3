"""Binary STL in millimetres: a deterministic writer (numpy, no timestamps in the header)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from assetgen.core.mesh import Mesh, StoredMesh, cross3

HEADER = b"assetgen binary STL; units: millimetres".ljust(80, b" ")
_RECORD = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])


def stl_bytes(mesh: Mesh, scale: float = 1000.0) -> bytes:
    """The mesh (metres) as binary STL bytes in millimetres (`scale` = mm per m)."""
    return stl_bytes_many([mesh], scale)[0]


def stl_bytes_many(meshes: list[Mesh], scale: float = 1000.0) -> list[bytes]:
    """stl_bytes of each mesh, byte for byte, computed for all of them at once: a module's
    ~30 small pieces would otherwise pay numpy's per-call cost ~30 times."""
    if not meshes:
        return []
    tri = np.vstack([m.vertices[m.faces] for m in meshes]) * scale
    normal = cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    rec = np.zeros(len(tri), dtype=_RECORD)
    rec["normal"] = normal
    rec["v"] = tri
    body = rec.tobytes()
    out, start = [], 0
    for m in meshes:
        end = start + len(m.faces)
        out.append(HEADER + np.uint32(len(m.faces)).tobytes() + body[50 * start : 50 * end])
        start = end
    return out


def read_stl_mm(path: Path) -> StoredMesh:
    """Read a binary STL in millimetres back as a Mesh in metres (see parse_stl_mm)."""
    return parse_stl_mm(Path(path).read_bytes(), str(path))


def parse_stl_mm(data: bytes, name: str = "STL") -> StoredMesh:
    """Binary STL bytes in millimetres as a Mesh in metres, merging vertices stored with
    identical coordinates (what a slicer or a mesh library does on load)."""
    return merge_vertices([parse_stl_triangles_mm(data, name)])[0]


def merge_vertices(tris: list[np.ndarray]) -> list[StoredMesh]:
    """Triangle soups (m_i, 3, 3) of float32-millimetre corners (in metres: as parsed from
    an STL, or rounded by inline_mesh.stored) as StoredMeshes, merging corners stored with
    identical bytes within each, with one sort for all of them (a module's ~30 pieces would
    otherwise pay np.unique's fixed cost ~30 times). Vertices come in the order of their
    bytes, the same for the generator's checks and the simulator. The writers store one sign
    of zero (see collision.pieces), so coordinates that compare equal have equal bytes."""
    counts = np.array([3 * len(t) for t in tris], dtype=np.int64)
    points = np.vstack([t.reshape(-1, 3) for t in tris]) if tris else np.zeros((0, 3))
    owner = np.repeat(np.arange(len(tris), dtype=">u8"), counts)
    # one key of 32 bytes a stored corner: its mesh (big-endian, so byte order is mesh order),
    # then its coordinates' bytes; np.unique over raw bytes is far faster than over rows
    keys = np.empty((len(points), 4), np.float64)
    keys.view(">u8")[:, 0] = owner
    keys[:, 1:] = points
    _, first, index = np.unique(
        keys.view(np.dtype((np.void, 32))).ravel(), return_index=True, return_inverse=True
    )
    unique, unique_owner = points[first], owner[first].astype(np.int64)
    start = np.searchsorted(unique_owner, np.arange(len(tris)))
    stop = np.searchsorted(unique_owner, np.arange(len(tris)), side="right")
    bounds = np.concatenate([[0], np.cumsum(counts)])
    return [
        StoredMesh(
            unique[start[i] : stop[i]],
            (index[bounds[i] : bounds[i + 1]] - start[i]).reshape(-1, 3).astype(np.int64),
        )
        for i in range(len(tris))
    ]


def read_stl_triangles_mm(path: Path) -> np.ndarray:
    """Triangles (m, 3, 3) in metres from a binary STL in millimetres, as stored (no merging).

    A plain numpy parse for the many small collision pieces, where a triangle soup is all a
    distance query needs; raises ValueError naming the file if it is not a whole binary STL.
    """
    return parse_stl_triangles_mm(Path(path).read_bytes(), str(path))


def parse_stl_triangles_mm(data: bytes, path: str = "STL") -> np.ndarray:
    """Triangles (m, 3, 3) in metres from binary STL bytes in millimetres (see above)."""
    if len(data) < 84:
        raise ValueError(f"{path}: {len(data)} bytes is too short for a binary STL")
    n = int(np.frombuffer(data, "<u4", 1, 80)[0])
    if len(data) != 84 + 50 * n:
        raise ValueError(
            f"{path}: header says {n} triangles ({84 + 50 * n} bytes) but the file has "
            f"{len(data)} bytes: truncated or not a binary STL"
        )
    rec = np.frombuffer(data, _RECORD, n, 84)
    tri = rec["v"].astype(np.float64) / 1000.0
    if not np.all(np.isfinite(tri)):
        raise ValueError(f"{path}: holds non-finite coordinates")
    return tri
