"""benchmarks/jams.py: a policy that presses the peg down beside the hole jams, and the report
says where (at the entrance's height, off the axis, pressing down)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import rl.checkpoint
import rl.run_state
from benchmarks import jams
from sim.task.expert import direct_expert_action
from tests.test_sim_common import sim_dataset


class OffAxis:
    """The scripted expert told that the hole is 8 mm off its true place: it aligns the peg
    above the plate beside the hole and then presses it down."""

    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        shifted = obs.copy()
        shifted[:, [0, 9]] += 0.008  # x in the entrance and in the bottom frame
        return direct_expert_action(shifted)


def test_a_peg_pressed_down_beside_the_hole_is_reported_as_a_jam(
    monkeypatch, tmp_path, capsys
) -> None:
    monkeypatch.setattr(rl.run_state, "load_agent", lambda path, device=None: (OffAxis(), {}))
    monkeypatch.setattr(rl.checkpoint, "read_counters", lambda path: {"env_steps": 4096})
    out = tmp_path / "jams.json"
    assert jams.main(["unused", "--dataset", str(sim_dataset()), "--modules", "2",
                      "--json", str(out)]) == 0  # fmt: skip
    res = json.loads(out.read_text())
    assert res["modules"] == 2 and res["successes"] == 0 and len(res["jams"]) == 2
    assert res["trained_env_steps"] == 4096  # which weights jammed
    for r in res["jams"]:
        assert 6.0 < r["offset_mm"] < 10.0
        assert abs(r["below_entrance_mm"]) < 5.0 and r["moved_mm"] < 1.0  # at the plate, held
        assert r["action_xyz"][2] < -0.1
    assert "2 jams" in capsys.readouterr().out


def test_robot_settings_are_checked_before_any_episode(capsys) -> None:
    from benchmarks.jams import main

    for argv, said in (
        (["--robot-set", "max_force=20"], "give --robot panda as well"),
        (["--robot", "panda", "--robot-set", "stiffness=3"], "ArmSettings's fields"),
        (["--robot", "panda", "--robot-set", "max_force=-1"], "max_force"),
    ):
        with pytest.raises(SystemExit) as e:
            main(["checkpoints/sac-teacher-free", *argv])
        assert e.value.code == 2 and said in capsys.readouterr().err
