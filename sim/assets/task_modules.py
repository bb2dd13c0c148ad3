"""A dataset's modules as the task runs them, whatever their family: Table I's modules as
they are (sim.assets.loading.load_dataset), and each module of a one-step assembly family
(profile, multi-peg) as its one step (sim.assets.assembly). A family of several steps
(profile-bolt) is played in sequence by the evaluation, not run as the task."""

from __future__ import annotations

from pathlib import Path

from sim.assets.assembly import AssemblyStages
from sim.assets.loading import AssetError, ModuleAsset, load_dataset


def load_modules(root: Path | str, ids: list[str] | None = None) -> list[ModuleAsset]:
    """Every module of the dataset at `root` (or the listed ids) as the task runs it; the
    files read are checked against the manifest as load_dataset and AssemblyStages do.
    AssetError for an assembly of several steps."""
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError

    try:
        ds = Dataset(root)
        family, assembly = ds.spec.family, ds.spec.assembly
        dirs = [ds.module_dir(mid) for mid in (ds.ids if ids is None else ids)]
    except DatasetError as e:
        raise AssetError(str(e)) from e
    if not assembly:  # Table I's layout: the modules as they are
        return load_dataset(root, ids)
    out = []
    for d in dirs:
        stages = AssemblyStages(d)
        if len(stages.steps) != 1:
            raise AssetError(
                f"{root}: a {family} assembly has {len(stages.steps)} steps; the task takes "
                "one-step families (profile, multi-peg); `assetgen eval` plays assemblies of "
                "several steps in sequence"
            )
        out.append(stages.stage(0))
    return out
