"""benchmarks/approach.py: where a policy's time to success goes, beside a scripted expert's."""

from __future__ import annotations

import json

import numpy as np

import rl.run_state
from benchmarks import approach
from sim.task.expert import direct_expert_action
from tests.test_sim_common import sim_dataset


class HalfSpeed:
    """The direct expert at half its commanded speed: the same path, later at every mark."""

    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        return 0.5 * np.clip(direct_expert_action(obs), -1.0, 1.0)


def test_a_slower_policy_reaches_every_mark_later(monkeypatch, tmp_path, capsys) -> None:
    monkeypatch.setattr(rl.run_state, "load_agent", lambda path, device=None: (HalfSpeed(), {}))
    out = tmp_path / "approach.json"
    assert approach.main(["unused", "--dataset", str(sim_dataset()), "--modules", "2",
                          "--json", str(out)]) == 0  # fmt: skip
    res = json.loads(out.read_text())
    slow, fast = res["policy"], res["scripted-direct"]
    assert fast["successes"] == 2 and slow["successes"] == 2
    assert slow["step_success"] > fast["step_success"] + 10
    assert slow["step_within_20mm"] > fast["step_within_20mm"]
    assert all(0 <= fast[f"step_within_{r:g}mm"] <= fast["step_success"] for r in (50, 5, 2))
    assert "step_success" in capsys.readouterr().out


def test_milestones_skip_unsuccessful_episodes() -> None:
    steps, n = 5, 2
    offset = np.array([[30.0, 30.0], [8.0, 30.0], [1.0, 30.0], [np.nan, 30.0], [np.nan, 30.0]])
    tr = {"offset_mm": offset, "height_mm": np.zeros((steps, n)),
          "tilt_deg": np.zeros((steps, n)), "success": np.array([3.0, np.nan])}  # fmt: skip
    m = approach.milestones(tr)
    assert m["successes"] == 1 and m["step_success"] == 3.0
    assert m["step_within_10mm"] == 1.0 and m["step_within_2mm"] == 2.0
    assert m["step_within_50mm"] == 0.0
    assert approach.milestones(tr | {"success": np.array([np.nan, np.nan])}) == {
        "episodes": 2, "successes": 0}  # fmt: skip
