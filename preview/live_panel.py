"""The Policy folder of the live preview: a trained policy run on the shown module (run,
pause, one step, new spawn), its frames drawn as they come from its stepping thread (the
true peg, the observed one beside it, time and success). A part of preview/server.py's
PreviewApp, which holds the GUI and the shared state these methods use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from preview.scene import PreviewError, md_escape

if TYPE_CHECKING:  # preview.live (and torch with it) is imported only with a policy
    from preview.live import LiveFrame, LivePolicy

LIVE_CAMERA_POSITION = (0.3, -0.4, 0.32)
LIVE_CAMERA_LOOK_AT = (0.0, 0.0, 0.1)
"""Camera with a policy: the task spawns the peg up to 25 cm beside and above the entrance,
beyond the default view of the plate."""


class LivePanelMixin:
    """PreviewApp's live-policy methods (see PreviewApp for the state)."""

    def _live_active(self) -> bool:
        """The policy's run on the shown module is what the scene shows."""
        frame = self.live.frame if self.live is not None else None
        return (
            self._live_shown
            and frame is not None
            and self.view is not None
            and frame.module_id == self.view.id
        )

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
                f"**{md_escape(name)}** policy {md_escape(str(live.checkpoint.parent))}  \n"
                f"episodes are recorded to {md_escape(str(live.record_dir))}"
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
