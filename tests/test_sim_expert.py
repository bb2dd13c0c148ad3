"""The scripted expert and the evaluation protocol on the small test set."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sim.evaluate import evaluate
from tests.test_sim_common import sim_dataset


def test_scripted_expert_inserts_with_noise_on(tmp_path: Path) -> None:
    res = evaluate(sim_dataset(), "scripted", attempts=2, seed=0, record=tmp_path / "rec")
    print({k: v for k, v in res.items() if k != "time_to_success_s"})
    assert res["episodes"] == 8
    assert res["success_rate"] >= 0.95
    assert len(res["time_to_success_s"]) == round(8 * res["success_rate"])
    assert 0 < res["median_time_to_success_s"] < 10
    files = sorted((tmp_path / "rec").glob("*.npz"))
    assert len(files) == 4  # the first attempt on each module, by default
    ep = np.load(files[0])
    assert ep["poses"].shape == (len(ep["reward"]), 7)
    assert str(ep["module_id"]) in res["per_module"]
    assert bool(ep["success"]) and math.isclose(float(ep["reward"].sum()), 1.0, abs_tol=1e-5)


def test_random_agent_does_not_insert() -> None:
    res = evaluate(sim_dataset(), "random", attempts=1, seed=0)
    assert res["episodes"] == 4 and res["success_rate"] == 0.0
    assert math.isnan(res["median_time_to_success_s"])
