"""The live browser preview: a viser server with a GUI to browse a dataset's modules.

`serve()` starts it (loopback only unless a host is given) and returns a ViewerHandle. Bad
input (missing dataset, unknown module, foreign or corrupt episode) is reported in the
terminal and in the page, and the server keeps running so another choice can be made there.
"""

from __future__ import annotations

import contextlib
import io
import ipaddress
import signal
import socket
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import viser
from rich.console import Console
from rich.markup import escape

from assetgen.dataset.reader import Dataset
from preview import nodes
from preview.episode import Episode, fit_notes, load_episode
from preview.scene import (
    DEFAULT_CUT_AZIMUTH_DEG,
    GRID_GAP_M,
    ModuleView,
    PreviewError,
    filter_ids,
    grid_positions,
    normalise_id,
    open_dataset,
)

if TYPE_CHECKING:  # preview.live (and torch with it) is imported only with a policy
    from preview.live import LiveFrame, LivePolicy

LOOPBACK_DEFAULT = "127.0.0.1"
TILT_MAX_DEG = 25.0
"""Upper end of the tilt filter slider, degrees (Table I: at most 15° about x and y, i.e.
about 21.2° in total)."""
SPEEDS = ("0.25", "0.5", "1", "2", "4")
VIEW_CACHE = 64
"""Module views kept in memory (a view is a few hundred kB at most)."""
LIVE_CAMERA_POSITION = (0.3, -0.4, 0.32)
LIVE_CAMERA_LOOK_AT = (0.0, 0.0, 0.1)
"""Camera with a policy: the task spawns the peg up to 25 cm beside and above the entrance,
beyond the default view of the plate."""


def is_loopback(host: str) -> bool:
    """True if `host` only accepts connections from this machine."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def exposure_warning(host: str) -> str | None:
    """The warning printed when the viewer listens beyond loopback (None on loopback)."""
    if is_loopback(host):
        return None
    return (
        f"the viewer listens on {host}: viser has no authentication, so anyone who can reach "
        "this port can see the dataset and drive the viewer; bind to 127.0.0.1 (the default) "
        "and use an SSH tunnel instead where possible"
    )


def start_server(host: str, port: int) -> viser.ViserServer:
    """A viser server on host:port (0: a free port), without viser's own banner (which would
    print the URL a second time and without our exposure warning)."""
    _check_bindable(host)
    with contextlib.redirect_stdout(io.StringIO()):
        return viser.ViserServer(host=host, port=port, verbose=False, label="assetgen preview")


def _check_bindable(host: str) -> None:
    """PreviewError unless `host` is an address of this machine: viser would otherwise retry
    1000 ports in its thread and never return."""
    try:
        infos = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
        family, _, _, _, addr = infos[0]
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind(addr)
    except OSError as e:
        raise PreviewError(
            f"cannot listen on host {host!r} ({e}); use 127.0.0.1 (default) or an address of "
            "this machine"
        ) from e


def stop_server(server: viser.ViserServer) -> None:
    """Stop a server (frees its port), without viser's "Server stopped" line."""
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()


def _url(host: str, port: int) -> str:
    shown = LOOPBACK_DEFAULT if host in ("0.0.0.0", "") else host
    if shown == "::":
        shown = "::1"
    if ":" in shown:
        shown = f"[{shown}]"
    return f"http://{shown}:{port}"


def _md_escape(text: str) -> str:
    out = []
    for ch in text:
        if ch in "\\`*_{}[]()#+-.!|<>~":
            out.append("\\" + ch)
        else:
            out.append(ch)
    return "".join(out)


class PreviewApp:
    """GUI and scene state of one viewer (shared by every connected browser tab).

    Public methods are what the GUI callbacks call; tests call them directly too. Every
    message for the user goes through `report` (terminal, page status, notification) and is
    kept in `messages` as (level, text).
    """

    def __init__(self, server: viser.ViserServer, console: Console | None = None):
        self.server = server
        self.console = console or Console(stderr=True)
        self.lock = threading.RLock()
        self.ds: Dataset | None = None
        self.view: ModuleView | None = None
        self.episode: Episode | None = None
        self.messages: list[tuple[str, str]] = []
        self.nodes: dict[str, Any] = {}
        self.grid_ids: list[str] = []
        self._cache: OrderedDict[str, ModuleView] = OrderedDict()
        self._stop_play = threading.Event()
        self._player: threading.Thread | None = None
        self._syncing = False
        self._grid_shown = False
        self.live: LivePolicy | None = None
        self._live_shown = False
        """The live run is what the scene shows (until an episode is loaded)."""
        server.gui.configure_theme(control_width="large", show_share_button=False)
        nodes.configure_camera(server)
        self._build_gui()

    # ------------------------------------------------------------------ GUI layout

    def _build_gui(self) -> None:
        gui = self.server.gui
        self.g_status = gui.add_markdown("")
        with gui.add_folder("Dataset"):
            self.g_dataset = gui.add_text("dataset", "", hint="spec name or dataset folder")
            self.g_open = gui.add_button("Open dataset")
        self.f_module = gui.add_folder("Module")
        with self.f_module:
            self.g_vertices = gui.add_dropdown("vertices", ("any",), hint="cross-section")
            self.g_tilt = gui.add_multi_slider(
                "hole tilt (°)", 0.0, TILT_MAX_DEG, 0.1, (0.0, TILT_MAX_DEG), min_range=0.0
            )
            self.g_match = gui.add_markdown("")
            self.g_module = gui.add_dropdown("module", ("-",))
            self.g_browse = gui.add_button_group("browse", ("◀ prev", "next ▶"))
            self.g_info = gui.add_markdown("")
            with gui.add_folder("parameters", expand_by_default=False):
                self.g_params = gui.add_markdown("")
        with gui.add_folder("Show"):
            self.g_show_peg = gui.add_checkbox("peg", True)
            self.g_show_body = gui.add_checkbox("module body", True)
            self.g_show_coll = gui.add_checkbox("collision pieces", False)
            self.g_show_entrance = gui.add_checkbox("entrance frame", True)
            self.g_show_bottom = gui.add_checkbox("bottom frame", True)
            self.g_lift = gui.add_slider(
                "peg lift (mm)", 0.0, 100.0, 0.1, 0.0, hint="along the hole axis; 0 = design pose"
            )
            self.g_section = gui.add_checkbox("section cut", False, hint="plane through the axis")
            self.g_cut = gui.add_slider(
                "cut azimuth (°)", -180.0, 180.0, 5.0, DEFAULT_CUT_AZIMUTH_DEG
            )
        with gui.add_folder("Grid", expand_by_default=False):
            self.g_grid = gui.add_checkbox("grid of modules", False, hint="the filtered modules")
            self.g_grid_n = gui.add_number("max modules", 16, min=1, max=400, step=1)
        self.f_episode = gui.add_folder("Episode")
        with self.f_episode:
            self.g_ep_path = gui.add_text("episode file", "", hint=".npz from assetgen eval")
            self.g_ep_load = gui.add_button("Load episode")
            self.g_ep_info = gui.add_markdown("no episode loaded")
            self.g_ep_step = gui.add_slider("step", 0, 1, 1, 0, disabled=True)
            self.g_ep_play = gui.add_button_group("playback", ("▶ play", "Ⅱ pause"))
            self.g_ep_speed = gui.add_dropdown("speed", SPEEDS, initial_value="1")
            self.g_ep_now = gui.add_markdown("")
        self.g_ep_plot: Any = None

        self.g_open.on_click(lambda _: self.open_dataset(self.g_dataset.value))
        self.g_vertices.on_update(lambda _: self._refilter())
        self.g_tilt.on_update(lambda _: self._refilter())
        self.g_module.on_update(lambda e: self._on_module(e.target.value))
        self.g_browse.on_click(lambda e: self.browse(-1 if "prev" in e.target.value else 1))
        for cb in (
            self.g_show_peg,
            self.g_show_body,
            self.g_show_coll,
            self.g_show_entrance,
            self.g_show_bottom,
        ):
            cb.on_update(lambda _: self._apply_visibility())
        self.g_lift.on_update(lambda _: self._place_peg())
        self.g_section.on_update(lambda _: self._update_section())
        self.g_cut.on_update(lambda _: self._update_section())
        self.g_grid.on_update(lambda _: self._update_grid())
        self.g_grid_n.on_update(lambda _: self._update_grid())
        self.g_ep_load.on_click(lambda _: self.load_episode(self.g_ep_path.value))
        self.g_ep_step.on_update(lambda _: self._place_peg())
        self.g_ep_play.on_click(lambda e: self.play() if "play" in e.target.value else self.pause())

    # ------------------------------------------------------------------ messages

    def report(self, level: str, text: str) -> None:
        """Tell the user: terminal (stderr), the page's status line and a notification."""
        self.messages.append((level, text))
        style = {"error": "bold red", "warning": "yellow"}.get(level, "cyan")
        self.console.print(f"[{style}]{level}:[/] {escape(text)}", highlight=False, soft_wrap=True)
        # Plain text, no emoji: headless and minimal systems often lack an emoji font.
        self.g_status.content = f"**{level.upper()}**: {_md_escape(text)}"
        color = {"error": "red", "warning": "yellow"}.get(level, "blue")
        for client in self.server.get_clients().values():
            client.add_notification(
                title=level,
                body=text,
                color=color,
                auto_close_seconds=None if level == "error" else 8.0,
            )

    def _clear_status(self) -> None:
        self.g_status.content = ""

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

    def _episode_active(self) -> bool:
        return (
            self.episode is not None
            and self.view is not None
            and self.episode.module_id == self.view.id
            and not self._live_active()
        )

    def _live_active(self) -> bool:
        """The policy's run on the shown module is what the scene shows."""
        frame = self.live.frame if self.live is not None else None
        return (
            self._live_shown
            and frame is not None
            and self.view is not None
            and frame.module_id == self.view.id
        )

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
            with self.server.atomic():
                peg.position = pos
                peg.wxyz = quat
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

    # ------------------------------------------------------------------ episodes

    def load_episode(self, path: str | Path) -> bool:
        """Load an episode of the open dataset and show its module; False + message on error."""
        self.pause()  # outside the lock: the player thread may be waiting for it
        self.live_pause()
        with self.lock:
            self.g_ep_path.value = str(path)
            if self.ds is None:
                self.report("error", "open a dataset before loading an episode")
                return False
            try:
                ep = load_episode(path, self.ds)
                view = self._load_view(ep.module_id)
            except PreviewError as e:
                self.report("error", str(e))
                return False
            self.episode = ep
            self._live_shown = False  # the episode takes the scene over
            # Clear the filters so the episode's module is listed.
            self.g_vertices.value = "any"
            self.g_tilt.value = (0.0, TILT_MAX_DEG)
            self.g_grid.value = False
            self.g_ep_step.max = max(1, ep.steps - 1)
            self.g_ep_step.value = 0
            self._remove("/episode")
            self.nodes["/episode"] = self.server.scene.add_frame("/episode", show_axes=False)
            self.nodes["/episode/path"] = nodes.add_path(self.server.scene, ep.poses[:, :3])
            if self.g_ep_plot is not None:
                self.g_ep_plot.remove()
            with self.f_episode:  # the plot goes beside the timeline
                self.g_ep_plot = self.server.gui.add_uplot(
                    data=(np.arange(ep.steps) * ep.dt, ep.reward, ep.returns),
                    series=(
                        {"label": "t (s)"},
                        {"label": "reward", "stroke": "#e6194b", "width": 1.5},
                        {"label": "return", "stroke": "#0082c8", "width": 1.5, "scale": "ret"},
                    ),
                    # x is seconds, not a date; the return gets its own axis on the right.
                    scales={"x": {"time": False}, "ret": {"auto": True}},
                    axes=({}, {"label": "reward"}, {"scale": "ret", "side": 1, "label": "return"}),
                    title="reward per step and return",
                    aspect=1.6,
                )
            status = "**success**" if ep.success else "**no success**"
            self.g_ep_info.content = (
                f"**{_md_escape(ep.path.name)}** on module {ep.module_id}: {ep.steps} steps × "
                f"{ep.dt * 1e3:.0f} ms = {ep.duration_s:.2f} s, return "
                f"{ep.returns[-1]:.3f}, {status}"
            )
            self._clear_status()
            self.show_module(view.id)
            self.report("info", f"loaded episode {ep.path.name} ({ep.steps} steps)")
            for note in (*ep.notes, *fit_notes(ep, view)):
                self.report("warning", note)
            return True

    def _reset_episode_gui(self) -> None:
        self._remove("/episode")
        if self.g_ep_plot is not None:
            self.g_ep_plot.remove()
            self.g_ep_plot = None
        self.g_ep_info.content = "no episode loaded"
        self.g_ep_now.content = ""
        self.g_ep_step.value = 0
        self.g_ep_step.disabled = True

    def _episode_gui_state(self) -> None:
        active = self._episode_active()
        self.g_ep_step.disabled = not active
        self.g_lift.disabled = active or self._live_active()
        if self.episode is not None and not active:
            self.g_ep_now.content = (
                "the policy's run is shown; load the episode again to replay it"
                if self._live_active()
                else f"the loaded episode ran on module {self.episode.module_id}; select it to "
                "replay"
            )

    def _episode_now(self) -> None:
        ep = self.episode
        assert ep is not None
        k = min(int(self.g_ep_step.value), ep.steps - 1)
        end = k == ep.steps - 1
        parts = [
            f"t = **{k * ep.dt:.2f} s** / {ep.duration_s:.2f} s",
            f"reward **{ep.reward[k]:+.3f}**",
            f"return {ep.returns[k]:+.3f}",
        ]
        if end:
            parts.append("ended")
        self.g_ep_now.content = (
            " · ".join(parts) + f"  \nepisode success: **{'yes' if ep.success else 'no'}**"
        )

    def play(self) -> None:
        """Replay the loaded episode from the current step in real time (× speed)."""
        with self.lock:
            if not self._episode_active():
                self.report("warning", "no episode of the shown module to play; load one")
                return
            if self._player is not None and self._player.is_alive():
                return
            assert self.episode is not None
            if self.g_ep_step.value >= self.episode.steps - 1:
                self.g_ep_step.value = 0
            self._stop_play.clear()
            self._player = threading.Thread(target=self._run_player, daemon=True)
            self._player.start()

    def pause(self) -> None:
        """Stop the replay at the current step."""
        self._stop_play.set()
        player = self._player
        if player is not None and player is not threading.current_thread():
            player.join(timeout=2.0)
        self._player = None

    @property
    def playing(self) -> bool:
        return self._player is not None and self._player.is_alive()

    def _run_player(self) -> None:
        ep = self.episode
        if ep is None:
            return
        t_next = time.perf_counter()
        while not self._stop_play.is_set():
            k = int(self.g_ep_step.value) + 1
            if k >= ep.steps or self.episode is not ep:
                return
            t_next += ep.dt / float(self.g_ep_speed.value)
            delay = t_next - time.perf_counter()
            if delay > 0 and self._stop_play.wait(delay):
                return
            self.g_ep_step.value = k  # the slider's callback moves the peg

    # ------------------------------------------------------------------ live policy

    def attach_policy(self, live: LivePolicy) -> None:
        """Add the Policy controls for `live` (run, pause, one step, new spawn) and show
        its runs: the true peg, the observed one beside it, time and success."""
        self.live = live
        live.on_step = self._live_frame
        live.on_error = self._live_error
        gui = self.server.gui
        name = live.algo + (f"-STACK {live.stack}" if live.stack > 1 else "")
        with gui.add_folder("Policy", order=self.f_module.order + 0.5):
            gui.add_markdown(
                f"**{_md_escape(name)}** policy {_md_escape(str(live.checkpoint.parent))}  \n"
                f"episodes are recorded to {_md_escape(str(live.record_dir))}"
            )
            self.g_live_run = gui.add_button_group("policy", ("▶ run", "Ⅱ pause", "step"))
            self.g_live_spawn = gui.add_button("new spawn", hint="another random start pose")
            self.g_show_observed = gui.add_checkbox(
                "observed peg", True, hint="the noisy pose the policy sees (blue wireframe)"
            )
            self.g_live_now = gui.add_markdown("pick a module and press run")
        actions = {"▶ run": self.live_run, "Ⅱ pause": self.live_pause, "step": self.live_step}
        self.g_live_run.on_click(lambda e: actions[e.target.value]())
        self.g_live_spawn.on_click(lambda _: self.live_spawn())
        self.g_show_observed.on_update(lambda _: self._apply_visibility())
        # The spawn volume is larger than the default view of the plate.
        self.server.initial_camera.position = LIVE_CAMERA_POSITION
        self.server.initial_camera.look_at = LIVE_CAMERA_LOOK_AT
        self._move_cameras(LIVE_CAMERA_POSITION, LIVE_CAMERA_LOOK_AT)
        if self.view is not None:
            self.show_module(self.view.id)  # adds the observed peg

    def _show_observed(self) -> bool:
        return self.live is not None and bool(self.g_show_observed.value)

    def _live_ready(self) -> bool:
        """Point the policy at the shown module and let its run take the scene over. Called
        outside the lock: switching modules waits for the stepping thread, which takes it."""
        assert self.live is not None
        with self.lock:
            if self.ds is None or self.view is None or self.g_grid.value:
                self.report("warning", "show one module (grid off) to run the policy on")
                return False
            module_dir = self.ds.module_dir(self.view.id)
        self.pause()  # the episode replay
        self._live_shown = True
        try:
            self.live.set_module(module_dir)
        except PreviewError as e:
            self.report("error", str(e))
            return False
        with self.lock:
            self._episode_gui_state()
            self._place_peg()
            self._apply_visibility()
        return True

    def live_run(self) -> None:
        """Run the policy on the shown module in real time (to the episode's end)."""
        if self.live is not None and self._live_ready():
            self.live.run()

    def live_pause(self) -> None:
        """Stop the policy's run where it is."""
        if self.live is not None:
            self.live.pause()

    def live_step(self) -> None:
        """One control step of the policy (pauses a run first)."""
        if self.live is not None and self._live_ready():
            self.live.step()

    def live_spawn(self) -> None:
        """A new random start pose for the shown module."""
        if self.live is not None and self._live_ready():
            self.live.spawn()

    def _live_frame(self, frame: LiveFrame) -> None:
        """Draw a step of the policy's run (from its stepping thread)."""
        with self.lock:
            view = self.view
            if view is None or frame.module_id != view.id or not self._live_active():
                if self.live is not None:
                    self.live.stop_soon()  # another module or an episode is shown now
                return
            self._place_peg()
            self.g_live_now.content = _live_markdown(frame)
            if frame.recording is not None:
                self.g_ep_path.value = str(frame.recording)  # "Load episode" replays it
                self.report(
                    "info",
                    f"module {frame.module_id}: {frame.ended} after {frame.time_s:.2f} s; "
                    f"recorded {frame.recording}",
                )

    def _live_error(self, text: str) -> None:
        with self.lock:
            self.report("error", text)

    def close(self) -> None:
        self.pause()
        if self.live is not None:
            self.live.close()


def _live_markdown(frame: LiveFrame) -> str:
    """Time, step, reward, success and the observation's error of a live frame."""
    d, deg = frame.observation_error()
    head = f"t = **{frame.time_s:.2f} s** (step {frame.step} / {frame.max_steps})"
    if frame.ended is not None:
        head += f", ended: **{frame.ended}**"
    return (
        f"{head}  \nreward {frame.reward:+.4f} · return {frame.episode_return:+.3f} · "
        f"success: **{'yes' if frame.success else 'no'}**  \n"
        f"observed − true: {d * 1e3:.2f} mm, {deg:.2f}°"
    )


@dataclass
class ViewerHandle:
    """A running viewer: its server, GUI state, and the URL it serves."""

    server: viser.ViserServer
    app: PreviewApp
    url: str
    host: str
    port: int

    def stop(self) -> None:
        """Stop replay and the server (frees the port)."""
        self.app.close()
        stop_server(self.server)

    def wait(self) -> None:
        """Block until Ctrl-C (or SIGTERM, from the main thread), then stop."""

        def _interrupt(*_: object) -> None:
            raise KeyboardInterrupt

        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, _interrupt)  # `kill` frees the port cleanly too
        try:
            while True:
                time.sleep(3600)
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()

    def __enter__(self) -> ViewerHandle:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def serve(
    dataset: str,
    *,
    module: str | None = None,
    episode: Path | str | None = None,
    host: str = LOOPBACK_DEFAULT,
    port: int | None = None,
    console: Console | None = None,
    policy: Path | str | None = None,
    record: Path | str | None = None,
) -> ViewerHandle:
    """Start the preview of `dataset` (spec name or folder) and return at once.

    Binds 127.0.0.1 on a free port unless `host`/`port` say otherwise (viser moves to the
    next free port if `port` is taken). Prints the URL; warns when `host` is not loopback
    (viser has no authentication). Bad input is reported in the terminal and the page and
    the server keeps running. Stop it with `handle.stop()` or block with `handle.wait()`.

    `policy` (a run or exported policy folder, or its checkpoint file) adds the Policy
    controls (preview/live.py); its episodes are written to `record` (default: a new
    temporary folder, printed). A policy that cannot be loaded or does not fit the task
    raises PreviewError before the server starts.
    """
    console = console or Console(stderr=True)
    try:
        ds = open_dataset(dataset)
        assembly = ds.spec.family != "peg-in-hole"
    except PreviewError:
        assembly = False  # the Table I viewer reports it in the page and keeps serving
    if assembly and policy is not None:
        raise PreviewError(
            f"{dataset} holds assemblies: the viewer shows their parts, steps and recorded "
            "attempts; a live policy plays on a peg-in-hole dataset (for assemblies: "
            "`assetgen eval --record DIR`, then --episode FILE)"
        )
    live = None
    if policy is not None:
        from preview.live import LivePolicy

        live = LivePolicy(policy, record)
        console.print(
            f"live policy: episodes are recorded to [bold]{live.record_dir}[/]", highlight=False
        )
    server = start_server(host, 0 if port is None else port)
    bound = server.get_port()
    url = _url(host, bound)
    console.print(f"assetgen preview: open [bold]{url}[/] (Ctrl-C stops)", highlight=False)
    if port is not None and bound != port:
        console.print(f"[yellow]warning:[/] port {port} is taken; using {bound}")
    warn = exposure_warning(host)
    if warn:
        console.print(f"[bold yellow]warning:[/] {escape(warn)}", highlight=False, soft_wrap=True)
    if assembly:
        from preview.assembly import AssemblyApp

        app_a = AssemblyApp(server, ds)
        if module is not None:
            app_a.show_module(module)
        if episode is not None:
            app_a.load_episode(episode)
        return ViewerHandle(server, app_a, url, host, bound)  # type: ignore[arg-type]
    app = PreviewApp(server, console)
    app.open_dataset(dataset, module=module)
    if live is not None:
        app.attach_policy(live)
    if episode is not None:
        app.load_episode(episode)
    return ViewerHandle(server, app, url, host, bound)
