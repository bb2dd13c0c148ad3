"""Exporting a run's policy: its networks without optimiser states, replay or RNG states,
with the run files that `assetgen report` reads."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import torch

from rl import checkpoint as ckpt
from rl.run_state import CHECKPOINT, agent_from

RUN_FILES = ("config.json", "metrics.csv")
"""Copied by `export_policy` with the weights: what `assetgen report` reads of a run."""


def export_policy(run: str | Path, out_dir: str | Path) -> dict[str, Any]:
    """Write a run's networks, without optimiser states, replay buffer or RNG states, to
    out_dir/checkpoint.safetensors (what `load_agent` and `assetgen eval --checkpoint` read;
    it cannot be resumed), with the run's config.json, metrics.csv and evaluation files.
    Returns {"files": {name: bytes}}. The folder is filled under a temporary name and then
    renamed, so an interrupted export leaves nothing half-written."""
    import shutil

    run = Path(run)
    src = run / CHECKPOINT if run.is_dir() else run
    tensors, doc = ckpt.load(src)
    if doc.get("policy_only"):
        raise ckpt.CheckpointError(f"{src} is already an exported policy")
    agent = agent_from(tensors, doc, src, "cpu")
    keep: dict[str, torch.Tensor] = {}
    nets = {k: m for k, m in agent.modules().items() if isinstance(m, torch.nn.Module)}
    out_doc = {
        "run": doc["run"],
        "counters": doc["counters"],
        "agent": ckpt.pack_modules(nets, "agent", keep),
        "policy_only": True,
        "versions": doc.get("versions", {}),
    }
    out_dir = Path(out_dir)
    if out_dir.exists():
        raise ckpt.CheckpointError(f"{out_dir} exists: choose a new folder for the export")
    tmp = out_dir.with_name(f".{out_dir.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    ckpt.save(tmp / CHECKPOINT, keep, out_doc)
    folder = src.parent
    for f in [*(folder / n for n in RUN_FILES), *sorted(folder.glob("eval_*.json"))]:
        if f.is_file():
            shutil.copy2(f, tmp / f.name)
    os.replace(tmp, out_dir)
    return {"files": {f.name: f.stat().st_size for f in sorted(out_dir.iterdir())}}
