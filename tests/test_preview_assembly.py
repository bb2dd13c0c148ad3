"""The viewer on an assembly dataset: the step slider walks the sequence (earlier parts
seated, the step's part lifted along its own axis, later parts not there yet), and what it
cannot do there (a policy, an episode) is refused before a server starts."""

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


def test_a_policy_or_an_episode_is_refused_on_assemblies(assemblies, tmp_path) -> None:
    with pytest.raises(PreviewError, match="holds assemblies"):
        serve(str(assemblies), console=Console(file=io.StringIO()), episode=tmp_path / "e.npz")
