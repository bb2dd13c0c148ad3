"""Assembly steps in the vector env: a part that is not convex collides as its pieces, and
the scripted expert inserts the profile (step 1) of profile-bolt assemblies at 0.25 mm."""

from __future__ import annotations

import collections
from dataclasses import replace

import numpy as np
import pytest

from assetgen.dataset.assembly_writer import write_assembly
from assetgen.families.profile_bolt import ProfileBoltSampler, build_profile_bolt
from sim.assets.assembly import load_stage
from sim.env import PegInHoleVecEnv
from sim.task.config import EVAL_CONFIG
from sim.task.expert import EXPERTS


@pytest.fixture(scope="module")
def slotted(tmp_path_factory):
    root = tmp_path_factory.mktemp("assembly")
    params = replace(ProfileBoltSampler().sample(0), slots=True)
    write_assembly("profile-bolt", params, build_profile_bolt(params), 0, root)
    return root / "000000"


def outcomes(asset, envs: int = 2, steps: int = 1500) -> collections.Counter:
    env = PegInHoleVecEnv([asset] * envs, num_envs=envs, config=EVAL_CONFIG)
    obs, seen = env.reset(seed=0), collections.Counter()
    for _ in range(steps):
        obs, _, term, trunc, info = env.step(EXPERTS["scripted"](obs))
        for e in np.flatnonzero(term | trunc):
            seen[
                "success"
                if info["success"][e]
                else "failure"
                if info["failure"][e]
                else "truncated"
            ] += 1
    return seen


def test_step_one_loads_with_the_profile_as_its_pieces(slotted) -> None:
    stage = load_stage(slotted, 0)
    assert stage.clearance == pytest.approx(0.25e-3) and len(stage.peg_pieces) > 1
    env = PegInHoleVecEnv([stage], num_envs=1, config=EVAL_CONFIG)
    assert env.sim.peg_ngeom[0] == len(stage.peg_pieces)
    # step 2's statics hold the profile's pieces where step 1 left it
    later = load_stage(slotted, 1)
    assert len(later.pieces) == len(stage.pieces) + len(stage.peg_pieces)
    moved = np.eye(4)
    moved[2, 3] = 0.01
    shifted = load_stage(slotted, 1, {"profile": moved})
    assert not np.allclose(shifted.pieces[-1].vertices, later.pieces[-1].vertices)


def test_the_expert_inserts_a_slotted_profile_only_as_its_pieces(slotted) -> None:
    """The same profile as one convex geom (its hull fills the T-slots) jams on the socket's
    keys; as its convex pieces the scripted expert inserts it every time."""
    stage = load_stage(slotted, 0)
    as_pieces = outcomes(stage)
    assert as_pieces["success"] >= 8 and set(as_pieces) == {"success"}
    as_hull = outcomes(replace(stage, peg_pieces=()))
    assert as_hull["success"] == 0


def test_the_expert_inserts_the_bolt_sideways_with_actions_in_the_entrance_frame(slotted):
    """Step 2's entrance is turned (the bolt goes in along -x, from spawns anywhere in the
    task's ranges about that frame): actions are velocities in the entrance frame and the
    failure rule measures from the entrance plane, so the expert written for Table I inserts
    the bolt through the block and the profile's cross hole every time."""
    stage = load_stage(slotted, 1)
    assert not np.allclose(stage.entrance[:3, :3], np.eye(3))
    seen = outcomes(stage)
    assert seen["success"] >= 8 and set(seen) == {"success"}
