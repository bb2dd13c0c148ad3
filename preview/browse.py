"""Browsing a dataset in the live preview: opening it, the module filters (vertex count,
tilt), choosing and showing a module, the grid of modules, and the scene updates of the
shown module (peg pose, section cut, visibility, cameras). A part of preview/server.py's
PreviewApp, which holds the GUI and the shared state these methods use.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from preview import nodes
from preview.scene import (
    GRID_GAP_M,
    ModuleView,
    PreviewError,
    filter_ids,
    grid_positions,
    normalise_id,
    open_dataset,
)

TILT_MAX_DEG = 25.0
"""Upper end of the tilt filter slider, degrees (Table I: at most 15° about x and y, i.e.
about 21.2° in total)."""

VIEW_CACHE = 64
"""Module views kept in memory (a view is a few hundred kB at most)."""


class BrowseMixin:
    """PreviewApp's dataset, module and scene methods (see PreviewApp for the state)."""

    # ------------------------------------------------------------------ dataset and module

    def open_dataset(self, name: str | Path, module: str | None = None) -> bool:
        """Open a dataset (spec name or folder) and show `module` (default: its first)."""
        self.pause()  # outside the lock: the player thread may be waiting for it
        self.live_pause()
        with self.lock:
            self._live_shown = False
            self.g_dataset.value = str(name)
            try:
                ds = open_dataset(name)
            except PreviewError as e:
                self.report("error", str(e))
                return False
            self.ds = ds
            self.view = None
            self._cache.clear()
            self.episode = None
            self._reset_episode_gui()
            counts = sorted({int(r["params"]["n_vertices"]) for r in ds.records.values()})
            self.g_vertices.options = ("any", *(str(c) for c in counts))
            self.g_vertices.value = "any"
            self.g_tilt.value = (0.0, TILT_MAX_DEG)
            self._clear_status()
            self.report("info", f"opened {ds.root}: {len(ds)} modules")
            self._syncing = True
            try:
                self._refilter(select=False)
            finally:
                self._syncing = False
            first = ds.ids[0]
            if module is not None:
                try:
                    first = normalise_id(ds, module)
                except PreviewError as e:
                    self.report("error", f"{e}; showing module {first} instead")
                    self.show_module(first)
                    return False
            return self.show_module(first)

    def filtered_ids(self) -> list[str]:
        """Ids matching the GUI's vertex-count and tilt filters."""
        if self.ds is None:
            return []
        v = self.g_vertices.value
        lo, hi = self.g_tilt.value
        return filter_ids(
            self.ds.records,
            n_vertices=None if v == "any" else int(v),
            tilt_deg=(float(lo), float(hi)),
        )

    def _refilter(self, select: bool = True) -> None:
        with self.lock:
            if self.ds is None:
                return
            ids = self.filtered_ids()
            self.g_match.content = f"{len(ids)} of {len(self.ds)} modules match"
            if not ids:
                self.g_module.options = ("-",)
                self.report("warning", "no module matches the filters; widen them")
                return
            keep = self.view.id if self.view is not None and self.view.id in ids else ids[0]
            self.g_module.options = ids  # resets the value (and shows ids[0]) if needed
            if select and self.g_module.value != keep:
                self.g_module.value = keep
            if self.g_grid.value:
                self._update_grid()

    def browse(self, step: int) -> None:
        """Show the previous (-1) or next (+1) module among the filtered ones."""
        ids = list(self.g_module.options)
        if not ids or ids == ["-"]:
            return
        cur = self.g_module.value
        k = ids.index(cur) if cur in ids else -step
        self.g_module.value = ids[(k + step) % len(ids)]

    def _on_module(self, mid: str) -> None:
        if self._syncing:
            return
        if mid != "-" and (self.view is None or self.view.id != mid):
            self.show_module(mid)

    def _load_view(self, mid: str) -> ModuleView:
        assert self.ds is not None
        if mid in self._cache:
            self._cache.move_to_end(mid)
            return self._cache[mid]
        view = ModuleView(self.ds, mid)
        self._cache[mid] = view
        while len(self._cache) > VIEW_CACHE:
            self._cache.popitem(last=False)
        return view

    def show_module(self, module: str | int) -> bool:
        """Show one module (id as written or its number); False and a message if it fails."""
        with self.lock:
            if self.ds is None:
                self.report("error", "no dataset is open; open one first")
                return False
            try:
                mid = normalise_id(self.ds, module)
                view = self._load_view(mid)
            except PreviewError as e:
                self.report("error", str(e))
                return False
            self.view = view
            if mid in self.g_module.options:
                self.g_module.value = mid
            else:
                # Shown despite the filters (an episode's or --module's): list it anyway.
                self.g_module.options = (*self.g_module.options, mid)
                self.g_module.value = mid
            self._remove("/module")
            self.nodes.update(nodes.add_module(self.server.scene, view))
            self.arm = None
            if self.robot is not None:
                from preview.arm import ArmView

                try:
                    self.arm = ArmView(self.ds.module_dir(mid), self.robot)
                    self.nodes.update(nodes.add_arm(self.server.scene, self.arm))
                except PreviewError as e:
                    self.report("error", str(e))
            if self.live is not None:
                self.nodes["/module/observed"] = nodes.add_observed_peg(self.server.scene, view)
                if self.live.module_id != mid:
                    self.live.stop_soon()  # it plays another module: not worth stepping on
            self.g_info.content = view.header_markdown()
            self.g_params.content = view.params_markdown()
            lift_mm = view.max_lift_m * 1e3
            self.g_lift.max = round(lift_mm, 1)
            if self.g_lift.value > self.g_lift.max:
                self.g_lift.value = self.g_lift.max
            self._episode_gui_state()
            self._place_peg(section=False)
            self._update_section()
            self._apply_visibility()
            return True

    # ------------------------------------------------------------------ scene updates

    def _remove(self, prefix: str) -> None:
        for name in [n for n in self.nodes if n == prefix or n.startswith(prefix + "/")]:
            self.nodes.pop(name)
        handle = self.server.scene.get_handle_by_name(prefix)
        if handle is not None:
            handle.remove()

    def peg_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The peg's pose shown now (position m, quaternion wxyz), module frame: the live
        policy's when it runs on this module, else the episode step when an episode of this
        module is loaded, else the lift slider's."""
        assert self.view is not None
        if self._live_active():
            assert self.live is not None and self.live.frame is not None
            pose = self.live.frame.true_pose
            return pose[:3].copy(), pose[3:].copy()
        if self._episode_active():
            assert self.episode is not None
            k = int(self.g_ep_step.value)
            pose = self.episode.poses[min(k, self.episode.steps - 1)]
            return pose[:3].copy(), pose[3:].copy()
        return self.view.peg_pose(self.g_lift.value / 1e3)

    def _place_peg(self, section: bool = True) -> None:
        with self.lock:
            if self.view is None or "/module/peg" not in self.nodes:
                return
            pos, quat = self.peg_pose()
            peg = self.nodes["/module/peg"]
            arm = None
            if self.arm is not None:  # the live robot's own joints, else carried by the arm
                live = self.live.frame if self._live_active() and self.live is not None else None
                arm = self.arm.pose(pos, quat, None if live is None else live.joints)
            with self.server.atomic():
                peg.position = pos
                peg.wxyz = quat
                if arm is not None:
                    nodes.pose_arm(self.nodes, arm)
                if self._live_active() and "/module/observed" in self.nodes:
                    assert self.live is not None and self.live.frame is not None
                    seen = self.live.frame.observed_pose
                    self.nodes["/module/observed"].position = seen[:3]
                    self.nodes["/module/observed"].wxyz = seen[3:]
            if self._episode_active():
                self._episode_now()
            if section and self.g_section.value:
                self._update_section()

    def _update_section(self) -> None:
        with self.lock:
            self._remove("/section")
            if self.view is None or not self.g_section.value or self.g_grid.value:
                self._apply_visibility()
                return
            try:
                sec = self.view.section(azimuth_deg=self.g_cut.value, peg_pose=self.peg_pose())
            except PreviewError as e:
                self.report("error", str(e))
                return
            self.nodes.update(nodes.add_section(self.server.scene, sec))
            self._apply_visibility()

    def _apply_visibility(self) -> None:
        with self.lock:
            cut = bool(self.g_section.value) and not self.g_grid.value
            single = not self.g_grid.value
            want = {
                "/module": single,
                "/module/body": self.g_show_body.value and not cut,
                "/module/peg": self.g_show_peg.value and not cut,
                "/module/observed": self._live_active() and self._show_observed() and not cut,
                "/module/collision": self.g_show_coll.value,
                "/module/entrance": self.g_show_entrance.value,
                "/module/bottom": self.g_show_bottom.value,
                "/section/body": self.g_show_body.value,
                "/section/peg": self.g_show_peg.value,
                "/episode": single and self._episode_active(),
            }
            for name, on in want.items():
                if name in self.nodes:
                    self.nodes[name].visible = bool(on)

    def _update_grid(self) -> None:
        with self.lock:
            self._remove("/grid")
            self.grid_ids = []
            if self.g_grid.value and self.ds is not None:
                ids = self.filtered_ids()[: int(self.g_grid_n.value)]
                plates = [float(self.ds.records[i]["params"]["plate_size"]) for i in ids]
                spacing = max(plates, default=0.15) + GRID_GAP_M
                self.nodes["/grid"] = self.server.scene.add_frame("/grid", show_axes=False)
                for mid, pos in zip(ids, grid_positions(len(ids), spacing), strict=True):
                    try:
                        view = self._load_view(mid)
                    except PreviewError as e:
                        self.report("error", str(e))
                        continue
                    prefix = f"/grid/m{mid}"
                    self.nodes.update(
                        nodes.add_module(
                            self.server.scene,
                            view,
                            prefix,
                            collision=False,
                            frames=False,
                            position=pos,
                        )
                    )
                    self.nodes[f"{prefix}/label"] = self.server.scene.add_label(
                        f"{prefix}/label", mid, position=(-0.07, -0.07, 0.005)
                    )
                    # Clicking a plate opens that module on its own.
                    self.nodes[f"{prefix}/body"].on_click(lambda _, m=mid: self._pick(m))
                    self.grid_ids.append(mid)
                extent = spacing * max(1.0, np.sqrt(len(ids)))
                if not self._grid_shown:  # frame the grid once; later the user's camera stays
                    self._move_cameras((0.0, -0.8 * extent, 0.8 * extent), (0.0, 0.0, 0.0))
            elif self._grid_shown:
                self._move_cameras(nodes.CAMERA_POSITION, nodes.CAMERA_LOOK_AT)
            self._grid_shown = bool(self.g_grid.value and self.ds is not None)
            self._update_section()
            self._apply_visibility()

    def _pick(self, mid: str) -> None:
        self.g_grid.value = False
        self.g_module.value = mid

    def _move_cameras(self, position: tuple, look_at: tuple) -> None:
        for client in self.server.get_clients().values():
            with client.atomic():
                # viser moves look_at along with position: set position first.
                client.camera.position = position
                client.camera.look_at = look_at
