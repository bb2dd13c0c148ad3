"""`assetgen physics` on an assembly: each step's part dropped into its hole and pushed
sideways, with the earlier parts fixed where they were inserted and the later ones absent."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE
from assetgen.dataset.assembly_writer import write_assembly
from assetgen.families.profile_bolt import ProfileBoltSampler, build_profile_bolt
from assetgen.physics.mjcf_checks import _load
from assetgen.physics.report import check_assembly_step, failures


@pytest.fixture(scope="module")
def xml(tmp_path_factory):
    root = tmp_path_factory.mktemp("asm")
    params = replace(ProfileBoltSampler().sample(1), slots=False)
    write_assembly("profile-bolt", params, build_profile_bolt(params), 1, root)
    return root / "000001" / ASSEMBLY_MJCF_FILE


def test_each_step_sees_the_earlier_parts_fixed_and_the_later_ones_absent(xml) -> None:
    first = _load(xml, "profile")
    bolt_geoms = first.model.geom_bodyid == first.model.body("bolt").id
    assert first.model.njnt == 2 and not first.model.geom_contype[bolt_geoms].any()
    assert first.clearance == pytest.approx(0.25e-3) and len(first.geoms) >= 1
    second = _load(xml, "bolt")
    # the profile lost its free joint (it is part of the static scene now) and collides
    assert second.model.njnt == 1 and second.model.joint(0).name == "bolt_free"
    profile = second.model.geom_bodyid == second.model.body("profile").id
    assert second.model.geom_contype[profile].all() and second.clearance == pytest.approx(5e-4)
    np.testing.assert_allclose(second.bottom_rot[:, 2], [1.0, 0.0, 0.0], atol=1e-9)
    with pytest.raises(ValueError, match="no step moves a part 'nut'"):
        _load(xml, "nut")
    with pytest.raises(ValueError, match="timestep"):
        _load(xml, "profile", timestep=0.01)


def test_the_profile_settles_on_its_floor_and_no_push_passes_a_wall(xml) -> None:
    fig = check_assembly_step((xml, "profile", None))
    assert failures(fig) == [], fig
    assert fig["drop_rest_error"] < 0.2e-3 and fig["passed_through"] == 0.0
    assert fig["move_over_free"] < 0.1e-3 and fig["clearance"] == pytest.approx(0.25e-3)
