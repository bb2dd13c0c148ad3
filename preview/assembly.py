"""The browser preview of an assembly dataset (`assetgen view <assembly dataset>`): each
assembly's parts as their STL, a step slider that walks the sequence, and a lift slider
that draws the active step's part back along its insertion axis.

At step k (1-based) the parts of the steps before k sit at their design poses, the part of
step k is lifted the slider's distance out of its hole along the step's insertion axis (0:
seated), and the parts of later steps are not shown yet. The convex pieces the simulator
collides (from `assembly.xml`) can be shown instead of the surfaces, and each step's
entrance and bottom frames. Reads only the module's files.

An attempt recorded by `assetgen eval --dataset <assembly dataset> --record DIR` (one .npz,
evaluation/sequence.py's save_sequence) replays across its stages: a time slider over every stage's
steps, the earlier parts where that attempt pressed them home.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import viser

from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE, part_pieces, read_inline_meshes
from assetgen.core.mesh import Mesh
from assetgen.core.stl import read_stl_mm
from assetgen.dataset.reader import Dataset
from preview import nodes
from preview.scene import PreviewError

PART_COLORS = {"base": nodes.BODY_COLOR, "profile": nodes.PEG_COLOR, "bolt": (70, 110, 210)}


def _pose(frame: dict) -> np.ndarray:
    from assetgen.core.rotations import quat_to_matrix

    m = np.eye(4)
    m[:3, :3] = quat_to_matrix(np.asarray(frame["quat"], float))
    m[:3, 3] = np.asarray(frame["pos"], float)
    return m


@dataclass
class AssemblyView:
    """One assembly as the viewer shows it: surfaces and pieces per part (part frame, m),
    the steps (part, clearance, entrance, bottom, design pose, travel) from module.json."""

    id: str
    meta: dict
    surfaces: dict[str, Mesh]
    pieces: dict[str, list[Mesh]]

    @staticmethod
    def load(ds: Dataset, mid: str) -> AssemblyView:
        d = ds.module_dir(mid)
        try:
            meta = json.loads((d / "module.json").read_text())
            names = ["base", *(s["part"] for s in meta["steps"])]
            surfaces = {n: read_stl_mm(d / f"{n}.stl") for n in names}
            inline = read_inline_meshes((d / ASSEMBLY_MJCF_FILE).read_bytes(), ASSEMBLY_MJCF_FILE)
            pieces = {n: part_pieces(inline, n) for n in names}
        except (OSError, ValueError, KeyError) as e:
            raise PreviewError(
                f"assembly {mid} in {ds.root} is incomplete or corrupt ({e}); "
                f"run `assetgen check {ds.root}`"
            ) from e
        return AssemblyView(mid, meta, surfaces, pieces)

    @property
    def parts(self) -> list[str]:
        return [s["part"] for s in self.meta["steps"]]

    def axis(self, k: int) -> np.ndarray:
        """(3,) unit direction out of step k's hole (bottom to entrance), module frame."""
        s = self.meta["steps"][k]
        e, b = np.asarray(s["entrance"]["pos"]), np.asarray(s["bottom"]["pos"])
        return (e - b) / np.linalg.norm(e - b)

    def pose(self, part: str, step: int, lift_m: float) -> np.ndarray | None:
        """(4, 4) pose of `part` at 0-based `step` of the sequence with the active part
        lifted `lift_m`; None where the part is not there yet."""
        if part == "base":
            return np.eye(4)
        k = self.parts.index(part)
        if k > step:
            return None
        pose = _pose(self.meta["steps"][k]["design_pose"])
        if k == step:
            pose[:3, 3] += lift_m * self.axis(k)
        return pose

    def travel_m(self, step: int) -> float:
        return float(self.meta["steps"][step]["travel_m"])

    def markdown(self, step: int) -> str:
        s = self.meta["steps"][step]
        p = self.meta["params"]
        rows = [
            f"**assembly {self.id}**, step {step + 1} of {len(self.parts)}: "
            f"**{s['part']}** at {s['clearance'] * 1e3:g} mm",
            f"measured: {self.meta['checks']['steps'][step]['clearance_m'] * 1e3:.6f} mm"
            if "checks" in self.meta
            else "",
            "",
            "| parameter | value |",
            "|---|---|",
        ]
        rows += [f"| {k} | {v:.4g} |" if isinstance(v, float) else f"| {k} | {v} |"
                 for k, v in p.items()]  # fmt: skip
        return "\n".join(rows)


@dataclass
class SequenceEpisode:
    """A recorded attempt (evaluation/sequence.py's save_sequence) on one timeline: the stages'
    steps one after another."""

    assembly_id: str
    parts: list[str]
    poses: list[np.ndarray]
    """Per stage reached, (T_k, 7) the active part's position + quaternion (w x y z)."""
    outcome: np.ndarray
    placed: np.ndarray
    dt: float

    @staticmethod
    def load(path: str | Path) -> SequenceEpisode:
        try:
            with np.load(path) as z:
                parts = [str(p) for p in z["parts"]]
                outcome = z["outcome"].astype(int)
                poses = [z[f"poses_{k}"].astype(float) for k in range(len(outcome))]
                ep = SequenceEpisode(str(z["assembly_id"]), parts, poses, outcome,
                                     z["placed"].astype(float), float(z["dt"]))  # fmt: skip
        except (OSError, KeyError, ValueError) as e:
            raise PreviewError(
                f"{path}: not a recorded assembly sequence ({e}); record one with "
                "`assetgen eval --dataset <assembly dataset> --record DIR`"
            ) from e
        if not ep.poses or any(p.ndim != 2 or p.shape[1] != 7 or not len(p) for p in ep.poses):
            raise PreviewError(f"{path}: its stages hold no (T, 7) poses")
        return ep

    @property
    def steps(self) -> int:
        return sum(len(p) for p in self.poses)

    def at(self, t: int) -> dict[str, np.ndarray]:
        """(4, 4) pose of every part there at time step t (parts not there yet: absent)."""
        from assetgen.core.rotations import quat_to_matrix

        out: dict[str, np.ndarray] = {}
        for k, path in enumerate(self.poses):
            if t < len(path):
                pose = np.eye(4)
                pose[:3, :3] = quat_to_matrix(path[t, 3:])
                pose[:3, 3] = path[t, :3]
                out[self.parts[k]] = pose
                return out
            t -= len(path)
            out[self.parts[k]] = self.placed[k]  # pressed home, where it stays
        return out


class AssemblyApp:
    """The viewer's state and GUI for an assembly dataset (see the module docstring)."""

    def __init__(self, server: viser.ViserServer, ds: Dataset) -> None:
        self.server, self.ds = server, ds
        self.lock = threading.RLock()
        self.view: AssemblyView | None = None
        self.handles: dict[str, Any] = {}
        server.gui.configure_theme(control_width="large", show_share_button=False)
        nodes.configure_camera(server)
        gui = server.gui
        self.g_status = gui.add_markdown("")
        with gui.add_folder("Assembly"):
            ids = tuple(ds.ids) or ("-",)
            self.g_module = gui.add_dropdown("assembly", ids)
            self.g_browse = gui.add_button_group("browse", ("◀ prev", "next ▶"))
        with gui.add_folder("Sequence"):
            self.g_step = gui.add_slider("step", 1, 2, 1, 1, hint="which part goes in")
            self.g_lift = gui.add_slider(
                "lift (mm)", 0.0, 100.0, 0.1, 0.0, hint="the step's part, out of its hole"
            )
        with gui.add_folder("Show"):
            self.g_pieces = gui.add_checkbox("collision pieces", False, hint="instead of surfaces")
            self.g_frames = gui.add_checkbox("step frames", True)
        with gui.add_folder("parameters", expand_by_default=False):
            self.g_info = gui.add_markdown("")
        with gui.add_folder("Episode"):
            self.g_ep_path = gui.add_text(
                "episode file", "", hint=".npz from assetgen eval --record"
            )
            self.g_ep_load = gui.add_button("Load episode")
            self.g_ep_info = gui.add_markdown("no episode loaded")
            self.g_ep_step = gui.add_slider("time step", 0, 1, 1, 0, disabled=True)
        self.episode: SequenceEpisode | None = None
        self.g_ep_load.on_click(lambda _: self.load_episode(self.g_ep_path.value))
        self.g_ep_step.on_update(lambda _: self._place())
        self.g_module.on_update(lambda e: self.show(e.target.value))
        self.g_browse.on_click(lambda e: self.browse(-1 if "prev" in e.target.value else 1))
        self.g_step.on_update(lambda _: self.set_step(int(self.g_step.value)))
        self.g_lift.on_update(lambda _: self._place())
        self.g_pieces.on_update(lambda _: self._build())
        self.g_frames.on_update(lambda _: self._build())
        if ds.ids:
            self.show(ds.ids[0])

    def show_module(self, module: str | int) -> bool:
        """Show an assembly by id or number (as the Table I viewer's `--module`)."""
        from preview.scene import normalise_id

        try:
            mid = normalise_id(self.ds, module)
        except PreviewError as e:
            self.g_status.content = f"**error:** {e}"
            return False
        if self.g_module.value != mid:
            self.g_module.value = mid  # its callback shows it
            return self.view is not None and self.view.id == mid
        return self.show(mid)

    @property
    def step(self) -> int:
        """The shown step, 0-based."""
        return int(self.g_step.value) - 1

    def browse(self, delta: int) -> None:
        ids = self.ds.ids
        if self.view is not None and ids:
            i = (ids.index(self.view.id) + delta) % len(ids)
            self.g_module.value = ids[i]

    def show(self, mid: str) -> bool:
        """Show assembly `mid`; False and a message in the page if it cannot be read."""
        with self.lock:
            try:
                view = AssemblyView.load(self.ds, mid)
            except PreviewError as e:
                self.g_status.content = f"**error:** {e}"
                return False
            self.view = view
            self.g_status.content = ""
            self.g_step.max = len(view.parts)
            if self.g_step.value > self.g_step.max:
                self.g_step.value = self.g_step.max
            self._build()
            return True

    def load_episode(self, path: str | Path) -> bool:
        """Replay a recorded sequence attempt (its assembly is shown); False and a message in
        the page when the file cannot be read or its assembly is not in this dataset."""
        with self.lock:
            try:
                ep = SequenceEpisode.load(path)
                if ep.assembly_id not in self.ds.records:
                    raise PreviewError(
                        f"{path}: assembly {ep.assembly_id} is not in {self.ds.root}; open the "
                        "dataset it was recorded on"
                    )
            except PreviewError as e:
                self.g_status.content = f"**error:** {e}"
                return False
            self.episode = None
            if not self.show_module(ep.assembly_id):
                return False
            self.episode = ep
            self.g_ep_step.max = max(1, ep.steps - 1)
            self.g_ep_step.value = 0
            self.g_ep_step.disabled = False
            outcome = ", ".join(
                f"{p}: {('success', 'failure', 'truncated')[int(o)]}"
                for p, o in zip(ep.parts, ep.outcome, strict=False)
            )
            self.g_ep_info.content = f"**{ep.assembly_id}**, {ep.steps} steps ({outcome})"
            self._place()
            return True

    def close(self) -> None:
        """Nothing plays in the background here (ViewerHandle.stop calls it)."""

    def set_step(self, k: int) -> None:
        """Step k (1-based): its part lifted by the slider, earlier parts seated."""
        with self.lock:
            if self.view is None:
                return
            k = min(max(1, k), len(self.view.parts))
            if int(self.g_step.value) != k:
                self.g_step.value = k  # its callback builds
                return
            self._build()

    def _build(self) -> None:
        with self.lock:
            v = self.view
            if v is None:
                return
            for h in self.handles.values():
                h.remove()
            self.handles = {}
            scene = self.server.scene
            self.g_lift.max = round(1.2 * v.travel_m(self.step) * 1e3, 1)
            self.g_lift.value = min(self.g_lift.value, self.g_lift.max)
            show_pieces = bool(self.g_pieces.value)
            for part in ["base", *v.parts]:
                meshes = v.pieces[part] if show_pieces else [v.surfaces[part]]
                frame = scene.add_frame(f"/assembly/{part}", show_axes=False)
                self.handles[part] = frame
                for i, m in enumerate(meshes):
                    colour = (
                        nodes.PIECE_COLORS[i % len(nodes.PIECE_COLORS)]
                        if show_pieces
                        else PART_COLORS.get(part, nodes.BODY_COLOR)
                    )
                    scene.add_mesh_simple(
                        f"/assembly/{part}/mesh_{i:03d}", m.vertices, m.faces, color=colour,
                        flat_shading=True, opacity=0.7 if show_pieces else 1.0,
                    )  # fmt: skip
            if self.g_frames.value:
                s = v.meta["steps"][self.step]
                for key in ("entrance", "bottom"):
                    f = s[key]
                    self.handles[f"frame_{key}"] = scene.add_frame(
                        f"/assembly/frames/{key}", axes_length=nodes.FRAME_AXES_M,
                        axes_radius=nodes.FRAME_AXES_M / 30, origin_radius=nodes.FRAME_AXES_M / 15,
                        position=np.asarray(f["pos"], float), wxyz=np.asarray(f["quat"], float),
                    )  # fmt: skip
            self.g_info.content = v.markdown(self.step)
            self._place()

    def _place(self) -> None:
        """Put every part where the step and the lift say, or where the loaded episode has
        it at its time step (hide those not there yet)."""
        from assetgen.core.rotations import matrix_to_quat

        with self.lock:
            v = self.view
            if v is None:
                return
            lift = float(self.g_lift.value) / 1e3
            ep = self.episode if self.episode and self.episode.assembly_id == v.id else None
            at = ep.at(int(self.g_ep_step.value)) if ep is not None else None
            for part in ["base", *v.parts]:
                h = self.handles.get(part)
                if h is None:
                    continue
                if at is not None:
                    pose = at.get(part, np.eye(4) if part == "base" else None)
                else:
                    pose = v.pose(part, self.step, lift)
                h.visible = pose is not None
                if pose is not None:
                    h.position = pose[:3, 3]
                    h.wxyz = matrix_to_quat(pose[None, :3, :3])[0]
