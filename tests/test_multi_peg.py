"""The `multi-peg` family: 2-4 pegs of one carrier, each exactly its clearance from its hole,
the step framed by the reference hole so the task sees a peg; bad draws named."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from assetgen.core.rotations import quat_to_matrix
from assetgen.families.multi_peg import MultiPegParams, MultiPegSampler, build_multi_peg
from assetgen.params.module_params import ParamError
from tests.test_profile_bolt import TOL, _axis, gap, pieces_in_module


@pytest.mark.parametrize("seed", range(4))
def test_every_peg_sits_at_exactly_its_clearance_and_goes_straight_in(seed) -> None:
    p = MultiPegSampler().sample(seed)
    asm = build_multi_peg(p)
    (step,) = asm.steps
    base = [m.vertices for m in pieces_in_module(asm.base)]
    carrier = asm.parts[0]
    pegs = pieces_in_module(carrier)[: len(p.pegs)]  # one piece per peg, then the carrier
    for peg in pegs:  # each peg on its own: every one of them is at the clearance
        assert gap([peg.vertices], base) == pytest.approx(p.clearance, abs=TOL)
    whole = [m.vertices for m in pieces_in_module(carrier)]
    swept = [np.vstack([v, v + step.travel * _axis(step)]) for v in whole]
    assert gap(swept, base) >= p.clearance - TOL


def test_the_step_is_framed_by_the_reference_hole() -> None:
    """The carrier's frame is the first peg's bottom face, seated the clearance above the
    reference hole's floor: the task observes the carrier as it observes a peg."""
    p = MultiPegSampler().sample(2)
    asm = build_multi_peg(p)
    (step,) = asm.steps
    pose = asm.parts[0].pose
    bottom = np.eye(4)
    bottom[:3, :3] = quat_to_matrix(np.asarray(step.bottom.quat))
    bottom[:3, 3] = step.bottom.pos
    np.testing.assert_allclose(pose[:3, :3], bottom[:3, :3], atol=1e-12)
    np.testing.assert_allclose(pose[:3, 3], bottom[:3, 3] + p.clearance * bottom[:3, 2], atol=1e-12)
    assert p.pegs[0][:2] == (0.0, 0.0)


def test_the_sampler_draws_every_count_and_every_draw_builds() -> None:
    counts = Counter()
    for seed in range(40):
        p = MultiPegSampler().sample(seed)
        build_multi_peg(p)
        counts[len(p.pegs)] += 1
    assert set(counts) == {2, 3, 4}


def test_bad_parameters_are_named() -> None:
    p = MultiPegSampler().sample(1)
    assert MultiPegParams.from_json(p.to_json()) == p
    (_, _, n, r, a), *rest = p.pegs
    near = (r + 1e-3, 0.0, n, r, a)  # a second peg whose hole overlaps the first's
    with pytest.raises(ParamError, match="apart"):
        replace(p, pegs=(p.pegs[0], near)).validate()
    with pytest.raises(ParamError, match="2 to 4"):
        replace(p, pegs=p.pegs[:1]).validate()
    with pytest.raises(ParamError, match="reference"):
        replace(p, pegs=((0.01, 0.0, n, r, a), *rest)).validate()
    with pytest.raises(ParamError, match="sides"):
        replace(p, pegs=((0.0, 0.0, 9, r, a), *rest)).validate()


def test_a_dataset_is_written_checked_and_inserted_by_the_expert(tmp_path) -> None:
    from assetgen.dataset.check import check_dataset
    from assetgen.dataset.families import family
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from evaluation.sequence import evaluate_assembly_dataset
    from sim.task.expert import default_expert_action

    spec = DatasetSpec("m", 0, 3, MultiPegSampler(), family="multi-peg")
    s = generate(tmp_path / "m", spec, workers=1, progress=False)
    assert s.generated == 3 and not s.failures
    assert s.clearance_min_m == pytest.approx(1e-3, abs=1e-8)
    assert check_dataset(tmp_path / "m").ok
    res = evaluate_assembly_dataset(tmp_path / "m", default_expert_action, 1)
    assert res["sequence"]["success_rate"] == 1.0
    # the task (training) takes a one-step family's modules as they are
    from sim.assets.loading import AssetError
    from sim.assets.task_modules import load_modules
    from sim.env import PegInHoleVecEnv

    assets = load_modules(tmp_path / "m")
    assert [a.id for a in assets] == ["000000/carrier", "000001/carrier", "000002/carrier"]
    env = PegInHoleVecEnv(assets, num_envs=3, nthread=1)
    obs = env.reset(seed=0)
    for _ in range(50):
        obs = env.step(default_expert_action(obs))[0]
    assert np.isfinite(obs).all()
    # and joined with Table I's modules: one training set (`--dataset train+multi_peg_train`)
    from sim.env import make_train_env
    from tests.test_sim_common import sim_dataset

    mixed = make_train_env(f"{sim_dataset()}+{tmp_path / 'm'}", 4, 0)
    assert mixed.module_ids[-3:] == [a.id for a in assets]
    assert len(mixed.module_ids) == len(load_modules(sim_dataset())) + 3
    with pytest.raises(ValueError, match="same id"):
        make_train_env(f"{tmp_path / 'm'}+{tmp_path / 'm'}", 4, 0)
    bolts = DatasetSpec("b", 0, 1, family="profile-bolt", config=family("profile-bolt").sampler())
    generate(tmp_path / "b", bolts, workers=1, progress=False)
    with pytest.raises(AssetError, match="2 steps; the task takes one-step families"):
        load_modules(tmp_path / "b")
