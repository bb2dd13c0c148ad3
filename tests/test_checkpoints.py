"""The policies shipped in checkpoints/: each loads, acts and evaluates, and its evaluation
files are of the real splits, on the current physics (their table: docs/results/shipped/,
tests/test_results_pages.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from assetgen.core.mujoco_config import PHYSICS_VERSION

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted(p.parent for p in (ROOT / "checkpoints").glob("*/checkpoint.safetensors"))


def test_something_is_shipped() -> None:
    assert SHIPPED, "checkpoints/ holds no policy"


@pytest.mark.parametrize("folder", SHIPPED, ids=[p.name for p in SHIPPED])
def test_shipped_policy_evaluates(folder: Path, tmp_path: Path, monkeypatch) -> None:
    import torch

    from cli import main
    from rl.run_state import load_agent
    from tests.test_sim_common import sim_dataset

    torch.set_num_threads(1)
    agent, meta = load_agent(folder, "cpu")
    obs = np.zeros((3, meta["obs_dim"]), np.float32)
    act = agent.policy(obs)
    assert act.shape == (3, meta["act_dim"]) and np.isfinite(act).all()
    out = tmp_path / "eval.json"
    argv = ["eval", "--checkpoint", str(folder), "--dataset", str(sim_dataset()),
            "--attempts", "1", "--out", str(out)]  # fmt: skip
    monkeypatch.chdir(ROOT)
    assert main(argv) == 0
    res = json.loads(out.read_text())
    assert res["episodes"] == 4 and res["policy"] == "deterministic"
    # paths as a clone reads them: the run inside the repository relative to it, the
    # dataset outside it whole (assetgen/core/recorded_path.py)
    assert res["run"] == f"checkpoints/{folder.name}"
    assert res["dataset_folder"] == str(sim_dataset()) and res["dataset"] == str(sim_dataset())
    assert res["finished_envs"] == "parked"
    # the shipped evaluation files are of the real splits, under the paper's protocol; a
    # robustness file (scaled noise, a tighter clearance) says so in its name
    evals = sorted(folder.glob("eval_*.json"))
    assert evals, f"{folder} has no evaluation file"
    for f in evals:
        doc = json.loads(f.read_text())
        assert doc["attempts"] == 10 and doc["episodes"] == 10 * 1024, f
        assert doc["control_dt"] == 0.02 and len(doc["dataset_hash"]) == 64, f
        assert doc["dataset"] in ("train", "test", "test_c05", "test_c025"), f
        assert doc["noise_scale"] == 1.0 or f"noise{doc['noise_scale']:g}" in f.stem, f
        assert doc.get("physics_version") == PHYSICS_VERSION, f"{f}: other physics"
    assert {"eval_test.json"} <= {f.name for f in evals}, f"{folder}: no test-split evaluation"
