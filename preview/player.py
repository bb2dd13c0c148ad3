"""Replaying a recorded episode in the live preview: loading an episode file of the open
dataset, its timeline, reward plot and step readout, and playback in real time (× speed)
on a thread. A part of preview/server.py's PreviewApp, which holds the GUI and the shared
state these methods use.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np

from preview import nodes
from preview.browse import TILT_MAX_DEG
from preview.episode import fit_notes, load_episode
from preview.scene import PreviewError, md_escape

SPEEDS = ("0.25", "0.5", "1", "2", "4")


class PlayerMixin:
    """PreviewApp's episode methods (see PreviewApp for the state)."""

    def _episode_active(self) -> bool:
        return (
            self.episode is not None
            and self.view is not None
            and self.episode.module_id == self.view.id
            and not self._live_active()
        )

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
                f"**{md_escape(ep.path.name)}** on module {ep.module_id}: {ep.steps} steps × "
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
