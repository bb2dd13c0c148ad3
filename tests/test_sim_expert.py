"""The scripted expert and the evaluation protocol on the small test set, through the one
evaluation loop (`assetgen eval`)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from cli import main
from evaluation.protocol import evaluate
from evaluation.recording import EpisodeRecorder, env_labels
from sim import make_eval_env
from sim.task.expert import expert_action
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
    from sim.task.expert import FAST, fast_expert_action

    env = make_eval_env(str(sim_dataset()), None, 0)
    obs = np.concatenate([env.reset(seed=s) for s in range(8)]).astype(np.float64)
    turning_high = _turning(obs, FAST) & (obs[:, 2] > FAST.safe_height + 0.01)
    assert turning_high.sum() >= 4  # spawns are 15-25 cm up with any orientation
    slow, fast = expert_action(obs)[turning_high, 2], fast_expert_action(obs)[turning_high, 2]
    assert (slow >= 0).all() and (fast < 0).all()
    # below the safe height a turning peg rises with either gains
    low = obs.copy()
    low[:, 2] = FAST.safe_height - 0.05
    assert (fast_expert_action(low)[turning_high, 2] > 0).all()


def test_fast_expert_is_faster_on_the_same_spawns() -> None:
    from sim.task.expert import fast_expert_action

    runs = {}
    for name, policy in (("default", expert_action), ("fast", fast_expert_action)):
        env = make_eval_env(str(sim_dataset()), None, 0)
        runs[name] = evaluate(policy, env, 4, seed=3)
    assert runs["fast"]["success_rate"] >= 0.9
    slow, fast = (runs[k]["median_time_to_success_s"] for k in ("default", "fast"))
    assert fast < 0.85 * slow, (fast, slow)


def test_box_limits_keep_the_direction_and_use_the_whole_box() -> None:
    from sim.task.expert import _limit

    v = np.array([[0.5, 0.5, 0.0], [0.1, 0.0, 0.0]])
    norm, box = _limit(v, 0.25, False), _limit(v, 0.25, True)
    np.testing.assert_allclose(np.linalg.norm(norm[0]), 0.25)
    np.testing.assert_allclose(box[0], [0.25, 0.25, 0.0])  # sqrt(2) faster on the diagonal
    np.testing.assert_allclose(box[1], v[1])  # within the limits: unchanged
    np.testing.assert_allclose(norm[1], v[1])


def test_turn_reach_matches_hand_computed_tilts() -> None:
    """The lowest point of any Table I peg below its bottom-face centre: r sin(b) for an axis
    b from the vertical (b <= 90 deg), plus L |cos(b)| once it points down."""
    from sim.task.expert import DIRECT, _turn_reach

    def rot_x(a: float) -> np.ndarray:
        c, s = math.cos(a), math.sin(a)
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])

    r_ep = np.stack([rot_x(0.0), rot_x(math.pi / 2), rot_x(math.pi)])
    still = np.zeros((3, 3))  # no turn left: the reach at the current orientation
    deep = np.full(3, 1.0)  # a deep hole does not bound the length below Table I's 15 cm
    got = _turn_reach(r_ep, still, deep, DIRECT)
    np.testing.assert_allclose(got, [0.0, 0.03, 0.15], atol=1e-12)
    # the observed depth bounds the peg's length: a 2 cm deep hole, a peg of at most 5 cm
    np.testing.assert_allclose(_turn_reach(r_ep[2:], still[:1], np.array([0.02]), DIRECT), [0.05])
    # upright now, but the rest of the turn (about x, by 120 deg) ends pointing 30 deg below
    # horizontal: the worst orientation of the remaining arc counts, not the current one
    turn = np.array([[math.radians(120.0), 0.0, 0.0]])
    want = 0.03 * math.sin(math.radians(120.0)) + 0.15 * 0.5
    np.testing.assert_allclose(_turn_reach(r_ep[:1], turn, deep[:1], DIRECT), [want])


def test_direct_expert_turns_low_and_beats_the_fast_one() -> None:
    """The direct expert turns an upright-ish peg well below the fixed 16 cm, and succeeds at
    least as often as the fast expert, sooner, on the same spawns."""
    from sim.task.expert import DIRECT, FAST, _split, direct_expert_action, fast_expert_action

    env = make_eval_env(str(sim_dataset()), None, 0)
    obs = np.concatenate([env.reset(seed=s) for s in range(8)]).astype(np.float64)
    _, r_ep, _, _ = _split(obs)
    upright = r_ep[:, 2, 2] > 0.9  # peg axis within 26 deg of the surface normal
    assert upright.any()
    low = obs.copy()
    low[:, 2] = 0.08  # 8 cm up: below FAST's safe height, above DIRECT's for upright pegs
    assert (fast_expert_action(low)[upright & _turning(low, FAST), 2] > 0).all()  # rises
    assert (direct_expert_action(low)[upright & _turning(low, DIRECT), 2] <= 0).all()
    runs = {}
    for name, policy in (("fast", fast_expert_action), ("direct", direct_expert_action)):
        runs[name] = evaluate(policy, make_eval_env(str(sim_dataset()), None, 0), 4, seed=3)
    assert runs["direct"]["success_rate"] >= runs["fast"]["success_rate"]
    assert runs["direct"]["failure_rate"] == 0.0
    fast, direct = (runs[k]["median_time_to_success_s"] for k in ("fast", "direct"))
    assert direct < 0.85 * fast, (direct, fast)


def _turning(obs: np.ndarray, cfg) -> np.ndarray:
    """(n,) the expert's own test for phase 2: orientation error above cfg.turn_angle."""
    from assetgen.core.rotations import matrix_to_rotvec
    from sim.task.expert import _split

    _, r_ep, _, r_bp = _split(obs)
    r_eb = r_ep @ np.swapaxes(r_bp, 1, 2)
    return np.linalg.norm(matrix_to_rotvec(r_eb @ np.swapaxes(r_ep, 1, 2)), axis=1) > cfg.turn_angle


def test_demos_name_teaches_that_expert() -> None:
    """`train --demos NAME` learns from the expert that sim.task.expert names NAME."""
    from cli import teachers
    from sim.task.expert import EXPERTS

    given = teachers()
    for name, act in EXPERTS.items():
        assert given[name]() is act
