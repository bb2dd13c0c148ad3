"""The viewer on an assembly dataset: the step slider walks the sequence (earlier parts
seated, the step's part lifted along its own axis, later parts not there yet), a recorded
attempt replays across its stages, and a live policy is refused before a server starts."""

from __future__ import annotations

import io

import numpy as np
import pytest

pytest.importorskip("viser", reason="the `view` extra (viser) is not installed")

from rich.console import Console

from preview.scene import PreviewError
from preview.server import serve


@pytest.fixture(scope="module")
def assemblies(tmp_path_factory):
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.families.profile_bolt import ProfileBoltSampler

    root = tmp_path_factory.mktemp("view") / "pb"
    spec = DatasetSpec("pb", 0, 2, ProfileBoltSampler(), family="profile-bolt")
    assert not generate(root, spec, workers=1, progress=False).failures
    return root


def test_the_step_slider_walks_the_sequence(assemblies) -> None:
    h = serve(str(assemblies), console=Console(file=io.StringIO()), module="1")
    try:
        app = h.app
        v = app.view
        assert v.id == "000001" and v.parts == ["profile", "bolt"] and app.g_step.max == 2
        # step 1: the profile at its design pose (lift 0), the bolt not there yet
        assert app.handles["bolt"].visible is False
        design = v.pose("profile", 0, 0.0)
        np.testing.assert_allclose(app.handles["profile"].position, design[:3, 3])
        app.g_lift.value = 10.0
        np.testing.assert_allclose(
            app.handles["profile"].position, design[:3, 3] + 0.01 * v.axis(0), atol=1e-12
        )
        assert np.allclose(v.axis(0), [0, 0, 1])  # the profile goes in from above
        # step 2: the profile seated, the bolt drawn back along +x (it goes in along -x)
        app.set_step(2)
        assert app.step == 1 and app.handles["bolt"].visible is True
        np.testing.assert_allclose(app.handles["profile"].position, design[:3, 3])
        bolt = v.pose("bolt", 1, 0.0)[:3, 3]
        lift = app.g_lift.value / 1e3
        moved = np.add(bolt, [lift, 0.0, 0.0])
        np.testing.assert_allclose(app.handles["bolt"].position, moved, atol=1e-12)
        assert app.g_lift.max == pytest.approx(round(1.2 * v.travel_m(1) * 1e3, 1))
        app.g_pieces.value = True  # the collision pieces instead of the surfaces
        assert "bolt" in app.handles and app.show_module("999") is False
        assert "error" in app.g_status.content
    finally:
        h.stop()


def test_a_live_policy_is_refused_on_assemblies(assemblies, tmp_path) -> None:
    with pytest.raises(PreviewError, match="holds assemblies"):
        serve(str(assemblies), console=Console(file=io.StringIO()), policy=tmp_path / "run")


def test_a_recorded_attempt_replays_across_its_stages(assemblies, tmp_path) -> None:
    """`assetgen eval --record` on assemblies writes one file per attempt; the viewer plays
    it on one timeline: the profile's path, then the bolt's with the profile where it was
    pressed home."""
    from cli import main

    rec = tmp_path / "rec"
    assert main(["eval", "--agent", "scripted", "--dataset", str(assemblies), "--attempts", "1",
                 "--record", str(rec), "--record-limit", "1", "--json"]) == 0  # fmt: skip
    (path,) = sorted(rec.glob("*.npz"))
    assert path.name == "sequence_000000_0.npz"
    with np.load(path) as z:
        assert list(z["parts"]) == ["profile", "bolt"] and list(z["outcome"]) == [0, 0]
        n0, n1 = len(z["poses_0"]), len(z["poses_1"])
        placed = z["placed"]
        last = z["poses_0"][-1]
    assert n0 > 10 and n1 > 10 and np.isfinite(placed).all()
    # pressed home: the profile's lateral offset kept, its axial one removed
    assert abs(placed[0][0, 3] - last[0]) < 1e-6 and placed[0][2, 3] <= last[2] + 1e-9
    h = serve(str(assemblies), console=Console(file=io.StringIO()), episode=path)
    try:
        app = h.app
        assert app.view.id == "000000" and app.episode is not None
        assert app.g_ep_step.max == n0 + n1 - 1
        assert app.handles["bolt"].visible is False  # stage 1: the bolt is not there yet
        np.testing.assert_allclose(app.handles["profile"].position, z_first(path), atol=1e-6)
        app.g_ep_step.value = n0 + 5  # stage 2: the profile stays where it was pressed home
        assert app.handles["bolt"].visible is True
        np.testing.assert_allclose(app.handles["profile"].position, placed[0][:3, 3], atol=1e-9)
        assert app.load_episode(tmp_path / "missing.npz") is False
        assert "not a recorded assembly sequence" in app.g_status.content
    finally:
        h.stop()


def z_first(path):
    with np.load(path) as z:
        return z["poses_0"][0, :3].astype(float)
