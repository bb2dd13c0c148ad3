"""Checkpoints: one safetensors file holding every tensor, with the JSON (configuration,
counters, RNG states, optimiser hyperparameters) in its metadata. Never pickle.

Layout of a checkpoint file:
    tensors           name -> tensor, e.g. "net/actor.0.weight", "opt/state/0/exp_avg",
                      "rng/torch", "env/stack_history"
    metadata["format"]  FORMAT
    metadata["json"]    the JSON document (tensors inside it are {"__tensor__": name})
    metadata["sha256"]  digest of every tensor's bytes, in name order: corruption is detected

Files are written to a temporary name in the same folder, flushed, then renamed over the
old one (os.replace is atomic), so a crash mid-write leaves the previous checkpoint intact.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import torch

FORMAT = "rl-checkpoint/1"
FILE_NAME = "checkpoint.safetensors"
"""A run folder's checkpoint."""


class CheckpointError(RuntimeError):
    """A checkpoint is missing, corrupt, or from another configuration."""


# ----------------------------------------------------------------------------- trees


def pack(tree: Any, prefix: str, tensors: dict[str, torch.Tensor]) -> Any:
    """A JSON-able copy of `tree` (dicts, lists, tuples, scalars, tensors, numpy arrays):
    each tensor or array goes into `tensors` under prefix/path and is replaced by a marker."""
    if isinstance(tree, torch.Tensor | np.ndarray):
        is_np = isinstance(tree, np.ndarray)
        tensors[prefix] = torch.from_numpy(np.ascontiguousarray(tree)) if is_np else tree
        return {"__tensor__": prefix, "numpy": is_np}
    if isinstance(tree, dict):
        keys = list(tree)
        out = {str(k): pack(tree[k], f"{prefix}/{k}", tensors) for k in keys}
        if any(isinstance(k, int) for k in keys):  # JSON keys are strings: remember ints
            out["__int_keys__"] = [str(k) for k in keys if isinstance(k, int)]
        return out
    if isinstance(tree, list | tuple):
        return [pack(v, f"{prefix}/{i}", tensors) for i, v in enumerate(tree)]
    if isinstance(tree, np.generic):
        return tree.item()
    return tree


def unpack(tree: Any, tensors: dict[str, torch.Tensor]) -> Any:
    """Inverse of `pack` (lists stay lists; tensors come back as tensors or arrays)."""
    if isinstance(tree, dict):
        if "__tensor__" in tree:
            t = tensors[tree["__tensor__"]]
            return t.numpy() if tree.get("numpy") else t
        ints = set(tree.get("__int_keys__", []))
        return {
            (int(k) if k in ints else k): unpack(v, tensors)
            for k, v in tree.items()
            if k != "__int_keys__"
        }
    if isinstance(tree, list):
        return [unpack(v, tensors) for v in tree]
    return tree


def pack_modules(
    modules: dict[str, torch.nn.Module | torch.optim.Optimizer],
    prefix: str,
    tensors: dict[str, torch.Tensor],
) -> dict:
    """JSON of the state dicts of named modules and optimisers; tensors go into `tensors`."""
    return {name: pack(m.state_dict(), f"{prefix}/{name}", tensors) for name, m in modules.items()}


def load_modules(
    modules: dict[str, torch.nn.Module | torch.optim.Optimizer],
    doc: dict,
    tensors: dict[str, torch.Tensor],
) -> None:
    """Load what `pack_modules` saved into modules built the same way."""
    for name, m in modules.items():
        if name not in doc:
            raise CheckpointError(f"the checkpoint has no {name!r}; it holds {sorted(doc)}")
        state = unpack(doc[name], tensors)
        try:
            m.load_state_dict(state)
        except (RuntimeError, ValueError, KeyError) as e:
            raise CheckpointError(f"{name}: the checkpoint's state does not fit: {e}") from e


# ----------------------------------------------------------------------------- files


def _digest(tensors: dict[str, torch.Tensor]) -> str:
    h = hashlib.sha256()
    for k in sorted(tensors):
        h.update(k.encode())
        h.update(tensors[k].numpy().tobytes() if tensors[k].numel() else b"")
    return h.hexdigest()


def _plain(t: torch.Tensor) -> torch.Tensor:
    """A CPU tensor owning its memory (safetensors refuses views of larger storages)."""
    t = t.detach().cpu().contiguous()
    if t.untyped_storage().nbytes() != t.nbytes or t.storage_offset() != 0:
        t = t.clone()
    return t


def save(path: str | Path, tensors: dict[str, torch.Tensor], doc: dict[str, Any]) -> None:
    """Write tensors and the JSON document `doc` to `path` atomically."""
    from safetensors.torch import save_file

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    plain = {k: _plain(v) for k, v in tensors.items()}
    meta = {"format": FORMAT, "json": json.dumps(doc), "sha256": _digest(plain)}
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        save_file(plain, str(tmp), metadata=meta)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def load(path: str | Path) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    """(tensors on CPU, JSON document) of a checkpoint; CheckpointError when the file is
    missing, not a checkpoint, or corrupt."""
    from safetensors import SafetensorError, safe_open

    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}")
    try:
        with safe_open(str(path), framework="pt") as f:
            meta = f.metadata() or {}
            tensors = {k: f.get_tensor(k) for k in f.keys()}
    except (SafetensorError, OSError, ValueError, RuntimeError) as e:
        raise CheckpointError(
            f"{path} is corrupt or not a checkpoint ({e}); delete it, or restore a copy"
        ) from e
    if meta.get("format") != FORMAT:
        raise CheckpointError(
            f"{path} is a safetensors file but not a {FORMAT} checkpoint "
            f"(format {meta.get('format')!r})"
        )
    if _digest(tensors) != meta.get("sha256"):
        raise CheckpointError(
            f"{path} is corrupt: its tensors do not match their recorded SHA-256; delete it, "
            "or restore a copy"
        )
    try:
        doc = json.loads(meta["json"])
    except (KeyError, json.JSONDecodeError) as e:
        raise CheckpointError(f"{path} is corrupt: unreadable JSON metadata ({e})") from e
    return tensors, doc


def read_counters(path: str | Path) -> dict[str, Any]:
    """The training counters (iteration, env_steps, wall_s) of a checkpoint file or run
    folder, from its JSON metadata alone: the tensors are neither read nor checked, so this
    is cheap for a large replay buffer. {} for a checkpoint that holds none."""
    from safetensors import SafetensorError, safe_open

    path = Path(path)
    if path.is_dir():
        path = path / FILE_NAME
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}")
    try:
        with safe_open(str(path), framework="pt") as f:
            doc = json.loads((f.metadata() or {}).get("json", "{}"))
    except (SafetensorError, OSError, ValueError, RuntimeError) as e:
        raise CheckpointError(f"{path} is corrupt or not a checkpoint ({e})") from e
    return dict(doc.get("counters") or {})


def check_compatible(saved: dict[str, Any], wanted: dict[str, Any], path: str | Path) -> None:
    """Raise CheckpointError listing every key whose saved value differs from the wanted one
    (e.g. algorithm, observation size, stack, number of envs, hyperparameters)."""
    diffs = []
    for k in sorted(set(saved) | set(wanted)):
        a, b = saved.get(k, "<missing>"), wanted.get(k, "<missing>")
        if isinstance(a, dict) and isinstance(b, dict):
            diffs += [
                f"{k}.{kk}: checkpoint {a.get(kk, '<missing>')!r}, now {b.get(kk, '<missing>')!r}"
                for kk in sorted(set(a) | set(b))
                if a.get(kk, "<missing>") != b.get(kk, "<missing>")
            ]
        elif a != b:
            diffs.append(f"{k}: checkpoint {a!r}, now {b!r}")
    if diffs:
        raise CheckpointError(
            f"{path} was written by another configuration: "
            + "; ".join(diffs)
            + ". Resume with the same settings, or start a new run in another folder."
        )
