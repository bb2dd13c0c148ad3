"""What the preview shows, as plain numpy data (no viser): one module's meshes and frames in
metres, the peg lifted along the hole axis, the section cut, filters and the grid layout;
and `md_escape` for text shown in the GUI's markdown.

Everything here is in the module frame (origin at the centre of the plate's top surface,
z up), in metres; the STL files it reads are millimetres (see docs/module.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from assetgen.core.frames import Frame
from assetgen.core.inline_mesh import module_meshes
from assetgen.core.mesh import Mesh
from assetgen.core.rotations import quat_to_matrix
from assetgen.core.stl import read_stl_mm
from assetgen.dataset.reader import Dataset
from assetgen.dataset.spec import DatasetError, resolve

DEFAULT_CUT_AZIMUTH_DEG = 130.0
"""Default azimuth of the section plane's normal, degrees about the module z axis: points away
from the default camera (azimuth -50 deg), so the kept half shows its cut face to the viewer."""
GRID_GAP_M = 0.05
"""Gap between neighbouring plates in the grid layout, metres."""
LENGTH_PARAMS = frozenset(
    (
        "circumradius",
        "peg_height",
        "hole_x",
        "hole_y",
        "clearance",
        "plate_size",
        "plate_thickness",
        "sleeve_wall",
        "floor_thickness",
    )
)
"""Parameters in metres (shown in mm)."""
ANGLE_PARAMS = frozenset(("hole_tilt_x", "hole_tilt_y", "hole_yaw", "squash_angle"))
"""Parameters in radians (shown in degrees)."""


class PreviewError(RuntimeError):
    """Bad input to the preview (dataset, module id, episode); the message says what to do."""


def open_dataset(name: str | Path) -> Dataset:
    """A dataset by spec name (`train`) or folder path; PreviewError if it cannot be read."""
    try:
        root, _ = resolve(str(name))
        if not root.exists():
            raise PreviewError(
                f"dataset folder {root} does not exist; create it with "
                f"`assetgen sample --n N --out {root}` or pass another folder"
            )
        ds = Dataset(root)
    except DatasetError as e:
        raise PreviewError(str(e)) from e
    if not len(ds):
        raise PreviewError(f"{ds.root} holds no finished modules yet; run `assetgen sample` first")
    return ds


def normalise_id(ds: Dataset, module: str | int) -> str:
    """A module id as the dataset spells it: `3` and `000003` both name module 000003.

    Raises PreviewError naming the dataset's id range when the module is not in it.
    """
    text = str(module).strip()
    if text in ds.records:
        return text
    if text.isdigit():
        padded = f"{int(text):06d}"
        if padded in ds.records:
            return padded
    ids = ds.ids
    raise PreviewError(
        f"module {text!r} is not in {ds.root} ({len(ids)} modules, ids {ids[0]} .. {ids[-1]}); "
        "pick one of those ids"
    )


def hole_tilt_deg(params: Mapping[str, float]) -> float:
    """Angle between the hole axis and the module's z axis, degrees.

    The hole is tilted by hole_tilt_x about x and hole_tilt_y about y (radians); in either
    order the axis' z component is cos(tx) cos(ty), and the yaw about z does not change it.
    """
    c = math.cos(params["hole_tilt_x"]) * math.cos(params["hole_tilt_y"])
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def filter_ids(
    records: Mapping[str, Mapping],
    *,
    n_vertices: int | None = None,
    tilt_deg: tuple[float, float] | None = None,
) -> list[str]:
    """Ids (sorted) of the manifest records whose params match: cross-section vertex count
    (None: any) and hole tilt within [lo, hi] degrees (None: any)."""
    out = []
    for mid in sorted(records):
        p = records[mid]["params"]
        if n_vertices is not None and int(p["n_vertices"]) != n_vertices:
            continue
        if tilt_deg is not None:
            t = hole_tilt_deg(p)
            # Half a hundredth of a degree of slack: the GUI slider steps in 0.1 deg.
            if not (tilt_deg[0] - 5e-3 <= t <= tilt_deg[1] + 5e-3):
                continue
        out.append(mid)
    return out


def grid_positions(n: int, spacing: float) -> np.ndarray:
    """(n, 3) module-frame origins (metres) on a near-square grid, row by row along +x then -y,
    centred on the world origin, `spacing` metres apart."""
    cols = max(1, math.ceil(math.sqrt(n)))
    rows = max(1, math.ceil(n / cols))
    k = np.arange(n)
    x = (k % cols - (cols - 1) / 2.0) * spacing
    y = -(k // cols - (rows - 1) / 2.0) * spacing
    return np.stack([x, y, np.zeros(n)], axis=1)


def md_escape(text: str) -> str:
    """`text` with markdown's special characters backslash-escaped, for the GUI's markdown."""
    out = []
    for ch in text:
        if ch in "\\`*_{}[]()#+-.!|<>~":
            out.append("\\" + ch)
        else:
            out.append(ch)
    return "".join(out)


def _manifold(mesh: Mesh):
    import manifold3d

    m = manifold3d.Manifold(
        manifold3d.Mesh(
            vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
            tri_verts=np.asarray(mesh.faces, dtype=np.uint32),
        )
    )
    if m.status() != manifold3d.Error.NoError:
        raise PreviewError(f"section cut: mesh is not a closed manifold ({m.status()})")
    return m


def trim_by_plane(mesh: Mesh, normal: np.ndarray, point: np.ndarray) -> Mesh:
    """The closed part of `mesh` on the side of the plane that `normal` points to, with the
    cut capped (manifold3d: exact, watertight; trimesh's capping needs extra packages)."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    out = _manifold(mesh).trim_by_plane(tuple(n), float(n @ np.asarray(point, float))).to_mesh()
    v = np.asarray(out.vert_properties, dtype=np.float64)[:, :3]
    return Mesh(v, np.asarray(out.tri_verts, dtype=np.int64).reshape(-1, 3))


def plane_outline(mesh: Mesh, normal: np.ndarray, point: np.ndarray) -> np.ndarray:
    """(k, 2, 3) line segments where the plane cuts the mesh surface, metres."""
    import trimesh

    segs = trimesh.intersections.mesh_plane(
        mesh.to_trimesh(), plane_normal=np.asarray(normal, float), plane_origin=point
    )
    return np.asarray(segs, dtype=np.float64).reshape(-1, 2, 3)


@dataclass(frozen=True)
class Section:
    """A section cut through the hole axis: both halves kept on the `normal` side, capped."""

    normal: np.ndarray
    """(3,) unit normal of the cut plane (perpendicular to the hole axis), module frame."""
    point: np.ndarray
    """(3,) a point of the plane on the hole axis (the design-pose origin), metres."""
    body: Mesh
    """Module half, module frame, metres."""
    peg: Mesh
    """Peg half at the current lift, already placed in the module frame, metres."""
    outline: np.ndarray
    """(k, 2, 3) cut outline of module and peg, metres: shows the clearance gap as lines."""


class ModuleView:
    """One module as the preview shows it: meshes (metres), frames and the peg's pose."""

    def __init__(self, ds: Dataset, mid: str):
        paths = ds.paths(mid)  # DatasetError for an unknown id: callers normalise first
        try:
            self.info = ds.module_json(mid)
            self.peg = read_stl_mm(paths["peg_stl"])
            self.body = read_stl_mm(paths["module_stl"])
            # the pieces live inline in the MJCF; a dataset written without it shows none
            mjcf = paths["mjcf"]
            pieces = module_meshes(mjcf.read_bytes(), str(mjcf))[1] if mjcf.exists() else ()
            self.collision = list(pieces)
            self.frames = {k: Frame.from_json(v) for k, v in self.info["frames"].items()}
        except (OSError, ValueError, KeyError) as e:
            raise PreviewError(
                f"module {mid} in {ds.root} is incomplete or corrupt ({e}); "
                f"run `assetgen check {ds.root} --repair`"
            ) from e
        for need in ("entrance", "bottom", "design_pose"):
            if need not in self.frames:
                raise PreviewError(f"module {mid}: module.json has no {need!r} frame")
        self.id = mid
        self.params: dict = self.info["params"]
        self._body_cuts: dict[float, tuple[Mesh, np.ndarray]] = {}

    # ------------------------------------------------------------------ geometry

    @property
    def hole_axis(self) -> np.ndarray:
        """(3,) unit hole axis in the module frame, pointing out of the hole (bottom frame z)."""
        return self.frames["bottom"].z_axis

    @property
    def clearance_m(self) -> float:
        """Measured peg-to-module distance in the design pose, metres (FCL, as written)."""
        return float(self.info["checks"]["clearance_m"])

    @property
    def max_lift_m(self) -> float:
        """Largest useful lift, metres: the checked insertion travel (peg clear of the hole)."""
        travel = self.info.get("checks", {}).get("insertion_travel_m")
        if travel:
            return float(travel)
        return float(self.params["peg_height"]) * 1.2

    def peg_pose(self, lift_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Peg frame (position m, quaternion wxyz) in the module frame, moved `lift_m` metres
        out of the hole along its axis from the design pose (0 = design pose)."""
        d = self.frames["design_pose"]
        return np.asarray(d.pos) + lift_m * self.hole_axis, np.asarray(d.quat, dtype=float)

    def peg_matrix(self, lift_m: float = 0.0) -> np.ndarray:
        """(4, 4) transform peg frame -> module frame at `lift_m` (see peg_pose)."""
        pos, quat = self.peg_pose(lift_m)
        m = np.eye(4)
        m[:3, :3] = quat_to_matrix(quat)
        m[:3, 3] = pos
        return m

    def cut_normal(self, azimuth_deg: float = DEFAULT_CUT_AZIMUTH_DEG) -> np.ndarray:
        """Unit normal of a plane containing the hole axis: the horizontal direction at
        `azimuth_deg` (about module z) made perpendicular to the axis."""
        a = math.radians(azimuth_deg)
        n = np.array([math.cos(a), math.sin(a), 0.0])
        axis = self.hole_axis
        n = n - (n @ axis) * axis
        return n / np.linalg.norm(n)

    def section(
        self,
        lift_m: float = 0.0,
        azimuth_deg: float = DEFAULT_CUT_AZIMUTH_DEG,
        *,
        peg_pose: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> Section:
        """Section through the hole axis at `azimuth_deg`, the peg lifted `lift_m` metres
        (or at `peg_pose` = (position m, quaternion wxyz) in the module frame, e.g. an
        episode step)."""
        n = self.cut_normal(azimuth_deg)
        p = np.asarray(self.frames["design_pose"].pos, dtype=float)
        if peg_pose is None:
            m = self.peg_matrix(lift_m)
        else:
            m = np.eye(4)
            m[:3, :3] = quat_to_matrix(np.asarray(peg_pose[1], dtype=float))
            m[:3, 3] = peg_pose[0]
        peg_world = self.peg.transformed(m)
        key = round(float(azimuth_deg), 6)
        if key not in self._body_cuts:
            # The module half does not depend on the peg: cut it once per azimuth.
            self._body_cuts[key] = (trim_by_plane(self.body, n, p), plane_outline(self.body, n, p))
        body, body_outline = self._body_cuts[key]
        outline = np.concatenate([body_outline, plane_outline(peg_world, n, p)], axis=0)
        return Section(n, p, body, trim_by_plane(peg_world, n, p), outline)

    # ------------------------------------------------------------------ text

    def tilt_deg(self) -> float:
        """Angle between hole axis and module z, degrees (from the written bottom frame)."""
        return math.degrees(math.acos(float(np.clip(self.hole_axis[2], -1.0, 1.0))))

    def header_markdown(self) -> str:
        """Measured clearance, tilt and travel as markdown for the GUI."""
        checks = self.info["checks"]
        return "\n".join(
            [
                f"**module {self.id}** (seed {self.info.get('seed', '?')})  ",
                f"measured clearance: **{self.clearance_m * 1e3:.6f} mm** "
                f"(nominal {float(self.info['clearance']) * 1e3:.3f} mm)  ",
                f"hole tilt {self.tilt_deg():.2f}°, insertion travel "
                f"{self.max_lift_m * 1e3:.1f} mm, checks passed: {checks.get('passed')}",
            ]
        )

    def params_markdown(self) -> str:
        """Every sampled parameter as a markdown table (lengths in mm, angles in degrees)."""
        rows = [f"| {k} | {v} |" for k, v in self.param_rows()]
        return "\n".join(["| parameter | value |", "|---|---|", *rows])

    def param_rows(self) -> list[tuple[str, str]]:
        """(name, value with unit) per sampled parameter: lengths mm, angles degrees."""
        rows = []
        for key in sorted(self.params):
            v = self.params[key]
            if key in ANGLE_PARAMS:
                rows.append((key, f"{math.degrees(v):.2f}°"))
            elif key in LENGTH_PARAMS:
                rows.append((key, f"{v * 1e3:.3f} mm"))
            elif isinstance(v, float):
                rows.append((key, f"{v:.3f}"))
            else:
                rows.append((key, str(v)))
        return rows
