"""End to end in a real headless browser: Debian's Chromium driven by Playwright (its Python
package only; no `playwright install`, no downloaded browser). Opens the live viewer, waits
for the scene, switches the module through the GUI and checks that the rendered picture is
not blank and changes with the module; runs a trained policy live through the GUI and checks
that its time, success and the picture change; then opens an HTML snapshot from file:// with
the network off and checks it renders too.

Skipped only when /usr/bin/chromium is absent (CI: apt-get install chromium).
"""

from __future__ import annotations

import io
import re
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = Path("/usr/bin/chromium")
if not CHROMIUM.exists():
    pytest.skip(f"{CHROMIUM} is absent (apt-get install chromium)", allow_module_level=True)

from PIL import Image  # noqa: E402
from playwright.sync_api import Page, sync_playwright  # noqa: E402
from rich.console import Console  # noqa: E402

from assetgen.dataset.generate import generate  # noqa: E402
from assetgen.dataset.spec import DatasetSpec  # noqa: E402
from assetgen.params.sampler import SamplerConfig  # noqa: E402
from preview.server import serve  # noqa: E402
from preview.snapshot import write_html  # noqa: E402

ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
VIEWPORT = {"width": 1100, "height": 720}
SCENE = {"x": 0, "y": 160, "width": 660, "height": 540}
"""Screenshot clip (CSS px): the 3D view left of viser's control panel (whose text changes
with the module too), below the corner notification that software WebGL triggers."""


@pytest.fixture(scope="module")
def preview_dataset(tmp_path_factory) -> Path:
    """Six modules (seeds 0-5) with STL and collision pieces only: what the preview reads
    (independent of the simulation exporters, and quick)."""
    root = tmp_path_factory.mktemp("preview") / "ds"
    spec = DatasetSpec("preview", 0, 6, SamplerConfig(), ("collision",))
    assert not generate(root, spec, workers=1, progress=False).failures
    return root


@pytest.fixture
def page(tmp_path) -> Iterator[Page]:
    profile = tempfile.mkdtemp(prefix="chromium-profile-", dir=tmp_path)  # fresh user-data-dir
    with sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            profile,
            executable_path=str(CHROMIUM),
            headless=True,
            args=ARGS,
            viewport=VIEWPORT,
        )
        try:
            yield ctx.pages[0] if ctx.pages else ctx.new_page()
        finally:
            ctx.close()
            shutil.rmtree(profile, ignore_errors=True)


def _pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)


def _wait_for(cond: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.time() + timeout
    while time.time() < deadline:
        if cond():
            return
        time.sleep(0.25)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


def _shot_until(page: Page, ok: Callable[[np.ndarray], bool], timeout: float, what: str):
    """Screenshot the scene until `ok(pixels)`; returns (png bytes, pixels)."""
    deadline = time.time() + timeout
    while True:
        png = page.screenshot(clip=SCENE)
        px = _pixels(png)
        if ok(px):
            return png, px
        if time.time() > deadline:
            raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(0.5)


def _settled(page: Page, timeout: float, what: str, clip: dict = SCENE) -> tuple[bytes, np.ndarray]:
    """A non-blank screenshot equal to the one taken 1 s before (lighting and environment map
    faded in, GUI updates applied), so later differences come from the scene itself."""
    deadline = time.time() + timeout
    prev = None
    while True:
        png = page.screenshot(clip=clip)
        px = _pixels(png)
        if prev is not None and _not_blank(px) and float(np.abs(px - prev).mean()) < 0.2:
            return png, px
        if time.time() > deadline:
            raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")
        prev = px
        time.sleep(1.0)


def _not_blank(px: np.ndarray) -> bool:
    # A rendered module: a good share of pixels differ from the white background.
    return float((np.abs(px - 255.0).sum(axis=2) > 60).mean()) > 0.02


def test_live_viewer_renders_and_switches_module(page: Page, preview_dataset, tmp_path):
    handle = serve(str(preview_dataset), console=Console(file=io.StringIO()))
    requests: list[str] = []
    page.on("request", lambda r: requests.append(r.url))
    try:
        page.goto(handle.url)
        page.wait_for_selector("canvas", timeout=60_000)
        _wait_for(lambda: len(handle.server.get_clients()) >= 1, 30, "the websocket client")
        select = page.get_by_role("combobox", name="module", exact=True)
        select.wait_for(timeout=30_000)
        assert select.input_value() == "000000"
        before_png, before = _settled(page, 90, "the module to render")
        (tmp_path / "module_000000.png").write_bytes(before_png)

        # Switch the module through the GUI: open the dropdown, click another id.
        select.click()
        page.get_by_role("option", name="000003", exact=True).click()
        _wait_for(lambda: handle.app.view.id == "000003", 30, "the server to switch module")
        assert select.input_value() == "000003"

        def changed(px: np.ndarray) -> bool:
            return _not_blank(px) and float(np.abs(px - before).mean()) > 1.0

        _shot_until(page, changed, 60, "the picture to change")
        after_png, after = _settled(page, 60, "the new module to render")
        (tmp_path / "module_000003.png").write_bytes(after_png)
        assert float((np.abs(after - before).sum(axis=2) > 60).mean()) > 0.01
        origin = handle.url.rstrip("/")
        foreign = [u for u in requests if not u.startswith((origin, "data:", "blob:"))]
        assert not foreign, f"the page fetched from elsewhere: {foreign[:5]}"
    finally:
        handle.stop()


def _changed_pixels(a: np.ndarray, b: np.ndarray) -> float:
    return float((np.abs(a - b).sum(axis=2) > 60).mean())


def test_live_policy_runs_from_the_gui(page: Page, tmp_path):
    pytest.importorskip("torch", reason="--policy needs the `rl` extra (torch)")
    from tests.test_preview_live import debug_policy
    from tests.test_sim_common import sim_dataset

    handle = serve(
        str(sim_dataset()),
        console=Console(file=io.StringIO()),
        policy=debug_policy(),
        record=tmp_path / "rec",
    )
    try:
        page.goto(handle.url)
        page.wait_for_selector("canvas", timeout=60_000)
        _wait_for(lambda: len(handle.server.get_clients()) >= 1, 30, "the websocket client")
        before_png, before = _settled(page, 90, "the module to render")
        (tmp_path / "live_before.png").write_bytes(before_png)
        clock = page.get_by_text(re.compile(r"t = \d+\.\d\d s \(step \d+ / 500\)"))
        page.get_by_role("button", name="▶ run", exact=True).click()
        _wait_for(lambda: handle.app.live.running, 30, "the run to start")
        clock.wait_for(timeout=30_000)
        first = clock.inner_text()
        _wait_for(lambda: clock.inner_text() != first, 10, "the time shown to advance")
        assert page.get_by_text(re.compile(r"success: (no|yes)")).is_visible()
        # The peg leaves the hole for its spawn and moves on: the picture changes.
        png, px = _shot_until(
            page, lambda px: _changed_pixels(px, before) > 0.001, 30, "the peg to move"
        )
        (tmp_path / "live_running.png").write_bytes(png)
        _shot_until(page, lambda p: _changed_pixels(p, px) > 0.0002, 15, "the peg to move on")
        handle.app.live_pause()
        assert handle.app.live.frame.step > 0
    finally:
        handle.stop()


def test_html_snapshot_renders_offline(page: Page, preview_dataset, tmp_path):
    out = write_html(str(preview_dataset), tmp_path / "snap.html", module="2")
    page.context.set_offline(True)
    requests: list[str] = []
    page.on("request", lambda r: requests.append(r.url))
    page.goto(out.as_uri())
    page.wait_for_selector("canvas", timeout=60_000)
    # Clip above the snapshot's info panel (bottom left): only the 3D view counts.
    png, _ = _settled(page, 90, "the snapshot to render", {**SCENE, "height": 420})
    (tmp_path / "snapshot.png").write_bytes(png)
    assert page.locator("#assetgen-info").inner_text().startswith("module 000002")
    assert all(u.startswith(("file:", "data:", "blob:")) for u in requests), requests[:5]


def test_assembly_viewer_renders_and_its_step_slider_moves_the_parts(page: Page, tmp_path):
    """An assembly dataset in the live viewer: the parts render, and moving to step 2 (the
    bolt appears, drawn back along its axis) changes the picture."""
    from assetgen.families.profile_bolt import ProfileBoltSampler

    root = tmp_path / "pb"
    spec = DatasetSpec("pb", 0, 1, ProfileBoltSampler(), family="profile-bolt")
    assert not generate(root, spec, workers=1, progress=False).failures
    handle = serve(str(root), console=Console(file=io.StringIO()))
    try:
        page.goto(handle.url)
        page.wait_for_selector("canvas", timeout=60_000)
        _wait_for(lambda: len(handle.server.get_clients()) >= 1, 30, "the websocket client")
        page.get_by_role("combobox", name="assembly", exact=True).wait_for(timeout=30_000)
        before_png, before = _settled(page, 90, "the assembly to render")
        (tmp_path / "assembly_step1.png").write_bytes(before_png)
        handle.app.g_lift.value = 30.0
        handle.app.set_step(2)

        def changed(px: np.ndarray) -> bool:
            return _not_blank(px) and _changed_pixels(px, before) > 0.002

        _shot_until(page, changed, 60, "the bolt to appear")
        after_png, _ = _settled(page, 60, "step 2 to render")
        (tmp_path / "assembly_step2.png").write_bytes(after_png)
    finally:
        handle.stop()
