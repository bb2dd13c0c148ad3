"""Assembly sequences under the evaluation protocol: each stage's successes carry on, their
parts pressed home where the agent left them, into the next stage; `assetgen eval` on an
assembly dataset reports every stage and the whole sequence."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from assetgen.core.mujoco_config import PHYSICS_VERSION
from assetgen.core.rotations import matrix_to_quat
from evaluation.command import eval_main
from evaluation.sequence import (
    evaluate_assembly_dataset,
    evaluate_sequence,
    is_assembly_dataset,
    pressed_home,
)
from sim.assets.assembly import AssemblyStages
from sim.env import eval_config
from sim.task.expert import EXPERTS


@pytest.fixture(scope="module")
def assemblies(tmp_path_factory):
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.families.profile_bolt import ProfileBoltSampler

    root = tmp_path_factory.mktemp("seq") / "pb"
    spec = DatasetSpec("pb", 0, 2, ProfileBoltSampler(), family="profile-bolt")
    assert not generate(root, spec, workers=1, progress=False).failures
    return root


def _rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def test_pressed_home_removes_the_axial_offset_only() -> None:
    design = np.eye(4)
    design[:3, :3] = _rot_x(np.pi / 2)  # an insertion axis that is not z
    design[:3, 3] = [0.01, 0.02, 0.03]
    axis = np.array([0.0, -2.0, 0.0])  # any length
    tilt = _rot_x(np.pi / 2 + 0.002)
    pos = design[:3, 3] + [0.0002, -0.004, -0.0001]  # 4 mm short of home, 0.22 mm aside
    home = pressed_home(pos, matrix_to_quat(tilt[None])[0], design, axis)
    assert np.allclose(home[:3, 3], design[:3, 3] + [0.0002, 0.0, -0.0001], atol=1e-12)
    assert np.allclose(home[:3, :3], tilt, atol=1e-12)


def test_the_expert_completes_both_stages_and_parts_stay_where_left(assemblies, monkeypatch):
    seen: list[tuple[int, dict]] = []
    real = AssemblyStages.stage

    def spy(self, step, placed=None):
        seen.append((step, {k: v.copy() for k, v in (placed or {}).items()}))
        return real(self, step, placed)

    monkeypatch.setattr(AssemblyStages, "stage", spy)
    res = evaluate_assembly_dataset(assemblies, EXPERTS["scripted"], 2, seed=0)
    assert res["parts"] == ["profile", "bolt"] and res["family"] == "profile-bolt"
    profile, bolt = res["stages"]
    assert profile["episodes"] == 4 and profile["success_rate"] == 1.0
    assert profile["clearance_m"] == [pytest.approx(0.25e-3)]
    assert bolt["episodes"] == 4 and bolt["success_rate"] == 1.0
    seq = res["sequence"]
    assert seq["successes"] == 4 and len(res["per_module"]) == 2
    # the sequence's time is each attempt's stage times summed
    both = np.add(profile["time_to_success_s"], bolt["time_to_success_s"])  # (assembly, attempt)
    assert seq["time_to_success_s"] == pytest.approx(both.tolist())
    # stage 2 was built once per attempt, with the profile pressed home where it was left:
    # as deep as its design pose, not exactly at it (the agent's lateral offset stays)
    later = [p for step, p in seen if step == 1]
    assert len(later) == 4
    stages = AssemblyStages(assemblies / "modules" / "000000")
    design, axis = stages.design_pose(0), stages.insertion_axis(0)
    for placed in later[:2]:  # sorted by (assembly, attempt): assembly 000000 first
        off = placed["profile"][:3, 3] - design[:3, 3]
        assert abs(off @ axis) < 1e-12 and 0 < np.linalg.norm(off) < 1e-3


def test_a_failed_stage_ends_its_attempt(assemblies) -> None:
    stay = lambda obs: np.zeros((len(obs), 6))  # noqa: E731  (never reaches the seat)
    config = eval_config()
    from dataclasses import replace

    dirs = sorted((assemblies / "modules").iterdir())
    res = evaluate_sequence(dirs, stay, 1, replace(config, max_steps=20), seed=0)
    assert res["stages"][0]["episodes"] == 2 and res["stages"][0]["successes"] == 0
    assert res["stages"][0]["truncation_rate"] == 1.0
    assert res["stages"][1]["episodes"] == 0 and res["sequence"]["success_rate"] == 0.0
    assert res["stages"][1]["success_rate_of_attempts"] == 0.0


def test_assetgen_eval_on_an_assembly_dataset(assemblies, tmp_path, capsys) -> None:
    from cli import main

    assert is_assembly_dataset(assemblies)
    out = tmp_path / "seq.json"
    code = main(["eval", "--agent", "scripted", "--dataset", str(assemblies), "--attempts", "1",
                 "--out", str(out)])  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0, text
    assert "stage 1: profile (0.25 mm)" in text and "whole sequence" in text
    saved = json.loads(out.read_text())
    assert saved["agent"] == "scripted" and saved["sequence"]["episodes"] == 2
    assert [s["part"] for s in saved["stages"]] == ["profile", "bolt"]
    assert "modules" not in saved
    assert saved["physics_version"] == PHYSICS_VERSION and saved["timestep"] == 0.00025
    code = main(["eval", "--agent", "scripted", "--dataset", str(assemblies), "--attempts", "1",
                 "--modules", "1", "--out", str(out)])  # fmt: skip
    assert code == 0, capsys.readouterr().out
    saved = json.loads(out.read_text())
    assert saved["modules"] == 1 and saved["sequence"]["episodes"] == 1


def test_a_policy_of_another_observation_size_is_refused_before_the_run(
    assemblies, tmp_path, capsys, monkeypatch
) -> None:
    import evaluation.sequence
    from rl.runner import train
    from tests.toy_env import ToyEnv

    train("sac", ToyEnv(2), "debug", steps=64, out_dir=tmp_path / "toy", progress=False,
          tensorboard=False)  # fmt: skip
    calls = []

    def run_sequence(*a, wrap, **kw):
        calls.append(1)
        return evaluate_assembly_dataset(*a, wrap=wrap, **kw)

    monkeypatch.setattr(evaluation.sequence, "evaluate_assembly_dataset", run_sequence)
    args = argparse.Namespace(run=tmp_path / "toy", dataset=str(assemblies), episodes=1,
                              envs=None, seed=0, device="cpu", stochastic=False, json=True,
                              out=None)  # fmt: skip
    assert eval_main(args) != 0
    err = capsys.readouterr()
    assert "takes observations of 4 values" in err.out + err.err and calls
