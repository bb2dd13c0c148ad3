"""The scripted expert and the evaluation protocol on the small test set, through the one
evaluation loop (`assetgen eval`)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from cli import main
from rl.evaluate import evaluate
from sim import make_eval_env
from sim.expert import expert_action
from sim.recording import EpisodeRecorder, env_labels
from tests.test_sim_common import sim_dataset


def test_scripted_expert_inserts_with_noise_on(tmp_path: Path) -> None:
    out = tmp_path / "scripted.json"
    argv = ["eval", "--agent", "scripted", "--dataset", str(sim_dataset()), "--attempts", "2",
            "--record", str(tmp_path / "rec"), "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    res = json.loads(out.read_text())
    assert res["agent"] == "scripted" and res["policy"] == "deterministic"
    assert res["episodes"] == 8 and res["attempts"] == 2
    assert res["control_dt"] == 0.02 and res["noise_scale"] == 1.0
    assert len(res["dataset_hash"]) == 64
    assert res["success_rate"] >= 0.95
    assert len(res["time_to_success_s"]) == round(8 * res["success_rate"])
    assert 0 < res["median_time_to_success_s"] < 10
    files = sorted((tmp_path / "rec").glob("*.npz"))
    assert len(files) == 4  # the first attempt on each module, by default
    ep = np.load(files[0])
    assert ep["poses"].shape == (len(ep["reward"]), 7)
    assert str(ep["module_id"]) in res["per_module"] and len(res["per_module"]) == 4
    assert bool(ep["success"]) and math.isclose(float(ep["reward"].sum()), 1.0, abs_tol=1e-5)


def test_recorded_episode_starts_at_its_spawn(tmp_path: Path) -> None:
    env = make_eval_env(str(sim_dataset()), None, 0)
    rec = EpisodeRecorder(tmp_path, limit=6)
    res = evaluate(expert_action, env, 2, seed=0, labels=env_labels(env), recorder=rec)
    assert rec.written == 6 and res["episodes"] == 8
    for f in sorted(tmp_path.glob("*.npz")):
        ep = np.load(f)
        # the first pose after the spawn is one control step away from it, not a jump
        step = np.linalg.norm(ep["poses"][0, :3] - ep["spawn_pose"][:3])
        assert step < 0.25 * 0.02 + 1e-3, f.name


def test_random_agent_does_not_insert(capsys) -> None:
    argv = ["eval", "--agent", "random", "--dataset", str(sim_dataset()), "--attempts", "1",
            "--json"]  # fmt: skip
    assert main(argv) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res["episodes"] == 4 and res["success_rate"] == 0.0
    assert res["policy"] == "stochastic"
    assert math.isnan(res["median_time_to_success_s"])


def test_noise_scale_zero_is_kept(capsys) -> None:
    argv = ["eval", "--agent", "scripted", "--dataset", str(sim_dataset()), "--attempts", "1",
            "--noise-scale", "0", "--json"]  # fmt: skip
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["noise_scale"] == 0.0


def test_eval_refuses_bad_input(capsys) -> None:
    d = str(sim_dataset())
    assert main(["eval", "--dataset", d]) == 2
    assert main(["eval", "--agent", "scripted", "--dataset", d, "--attempts", "0"]) == 2
    assert "--attempts 0" in capsys.readouterr().err
    assert main(["eval", "--agent", "scripted", "--dataset", d, "--noise-scale", "-1"]) == 2
    assert "--noise-scale -1" in capsys.readouterr().err
    assert main(["eval", "--agent", "scripted", "--dataset", d, "--stochastic"]) == 2
    assert "--checkpoint" in capsys.readouterr().err


def test_fast_expert_descends_while_turning_only_above_the_safe_height() -> None:
    from assetgen.core.rotations import matrix_to_rotvec
    from sim.expert import FAST, _split, fast_expert_action

    env = make_eval_env(str(sim_dataset()), None, 0)
    obs = np.concatenate([env.reset(seed=s) for s in range(8)])
    t_ep, r_ep, _, r_bp = _split(obs.astype(np.float64))
    r_eb = r_ep @ np.swapaxes(r_bp, 1, 2)
    angle = np.linalg.norm(matrix_to_rotvec(r_eb @ np.swapaxes(r_ep, 1, 2)), axis=1)
    turning_high = (angle > FAST.turn_angle) & (t_ep[:, 2] > FAST.safe_height + 0.01)
    assert turning_high.sum() >= 4  # spawns are 15-25 cm up with any orientation
    slow, fast = expert_action(obs)[turning_high, 2], fast_expert_action(obs)[turning_high, 2]
    assert (slow >= 0).all() and (fast < 0).all()
    # below the safe height a turning peg rises with either gains
    low = obs.copy()
    low[:, 2] = FAST.safe_height - 0.05
    assert (fast_expert_action(low)[turning_high, 2] > 0).all()


def test_fast_expert_is_faster_on_the_same_spawns() -> None:
    from sim.expert import fast_expert_action

    runs = {}
    for name, policy in (("default", expert_action), ("fast", fast_expert_action)):
        env = make_eval_env(str(sim_dataset()), None, 0)
        runs[name] = evaluate(policy, env, 4, seed=3)
    assert runs["fast"]["success_rate"] >= 0.9
    slow, fast = (runs[k]["median_time_to_success_s"] for k in ("default", "fast"))
    assert fast < 0.85 * slow, (fast, slow)


def test_box_limits_keep_the_direction_and_use_the_whole_box() -> None:
    from sim.expert import _limit

    v = np.array([[0.5, 0.5, 0.0], [0.1, 0.0, 0.0]])
    norm, box = _limit(v, 0.25, False), _limit(v, 0.25, True)
    np.testing.assert_allclose(np.linalg.norm(norm[0]), 0.25)
    np.testing.assert_allclose(box[0], [0.25, 0.25, 0.0])  # sqrt(2) faster on the diagonal
    np.testing.assert_allclose(box[1], v[1])  # within the limits: unchanged
    np.testing.assert_allclose(norm[1], v[1])
