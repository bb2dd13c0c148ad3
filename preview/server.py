"""The live browser preview: a viser server with a GUI to browse a dataset's modules.

`serve()` starts it (loopback only unless a host is given) and returns a ViewerHandle. Bad
input (missing dataset, unknown module, foreign or corrupt episode) is reported in the
terminal and in the page, and the server keeps running so another choice can be made there.

This module holds the server (start, stop, URL, exposure warning), `serve` and its
ViewerHandle, and PreviewApp: the GUI's layout, its shared state and its messages. The
app's methods come from preview/browse.py (dataset, modules, grid, scene updates),
preview/player.py (recorded episodes) and preview/live_panel.py (a live policy).
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

import viser
from rich.console import Console
from rich.markup import escape

from assetgen.dataset.reader import Dataset
from assetgen.families.registry import is_assembly
from preview import nodes
from preview.browse import TILT_MAX_DEG, BrowseMixin
from preview.episode import Episode
from preview.live_panel import LivePanelMixin
from preview.player import SPEEDS, PlayerMixin
from preview.scene import DEFAULT_CUT_AZIMUTH_DEG, ModuleView, PreviewError, md_escape, open_dataset

if TYPE_CHECKING:  # preview.live (and torch with it) is imported only with a policy
    from preview.live import LivePolicy

LOOPBACK_DEFAULT = "127.0.0.1"


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


class PreviewApp(BrowseMixin, PlayerMixin, LivePanelMixin):
    """GUI and scene state of one viewer (shared by every connected browser tab).

    Public methods are what the GUI callbacks call; tests call them directly too. Every
    message for the user goes through `report` (terminal, page status, notification) and is
    kept in `messages` as (level, text).
    """

    def __init__(
        self, server: viser.ViserServer, console: Console | None = None, robot: str | None = None
    ):
        self.server = server
        self.robot = robot
        """A registered robot shown holding the peg (None: the floating peg)."""
        self.arm: Any = None
        """The shown module's preview.arm.ArmView when a robot is shown."""
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
        self.g_status.content = f"**{level.upper()}**: {md_escape(text)}"
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

    def close(self) -> None:
        self.pause()
        if self.live is not None:
            self.live.close()


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
    robot: str | None = None,
) -> ViewerHandle:
    """Start the preview of `dataset` (spec name or folder) and return at once.

    Binds 127.0.0.1 on a free port unless `host`/`port` say otherwise (viser moves to the
    next free port if `port` is taken). Prints the URL; warns when `host` is not loopback
    (viser has no authentication). Bad input is reported in the terminal and the page and
    the server keeps running. Stop it with `handle.stop()` or block with `handle.wait()`.

    `policy` (a run or exported policy folder, or its checkpoint file) adds the Policy
    controls (preview/live.py); its episodes are written to `record` (default: a new
    temporary folder, printed). A policy that cannot be loaded or does not fit the task
    raises PreviewError before the server starts. `robot` (a registered robot's name) shows
    it holding the peg (preview/arm.py), and the live policy runs through it.
    """
    console = console or Console(stderr=True)
    try:
        ds = open_dataset(dataset)
        assembly = is_assembly(ds.spec.family)
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

        live = LivePolicy(policy, record, robot=robot)
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
    app = PreviewApp(server, console, robot=robot)
    app.open_dataset(dataset, module=module)
    if live is not None:
        app.attach_policy(live)
    if episode is not None:
        app.load_episode(episode)
    return ViewerHandle(server, app, url, host, bound)
