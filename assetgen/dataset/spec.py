"""Dataset specs: what a dataset holds (seeds, Table I config, formats) and where it lives.

A spec is named by a JSON file in the repository's `datasets/` folder (`train`, `test`) or
given by the path of a dataset folder; `resolve` maps a `--dataset` value to both.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from assetgen.dataset.families import DEFAULT_FAMILY, family
from assetgen.params.module_params import ParamError
from assetgen.params.sampler import SamplerConfig

SPEC_KEYS = {"name", "seed_start", "count", "config", "formats", "family", "print_offset_m"}
DEFAULT_FORMATS = ("mjcf", "usd")
SPECS_DIR = Path(__file__).resolve().parents[2] / "datasets"


class DatasetError(RuntimeError):
    """A dataset that cannot be used as asked; the message says how to proceed."""


@dataclass(frozen=True)
class DatasetSpec:
    """What a dataset holds: modules for seeds seed_start .. seed_start + count - 1."""

    name: str
    """Dataset name (also its folder name under datasets/ when given by name)."""
    seed_start: int
    """First module seed."""
    count: int
    """Number of modules."""
    config: SamplerConfig = field(default_factory=SamplerConfig)
    """The family's sampling ranges (Table I's SamplerConfig for peg-in-hole)."""
    formats: tuple[str, ...] = DEFAULT_FORMATS
    """Simulation formats written besides STL and 3MF (peg-in-hole; an assembly writes its
    MJCF and 3MF always)."""
    family: str = DEFAULT_FAMILY
    """What the modules are (assetgen.dataset.families): `peg-in-hole`, `profile`, ..."""
    print_offset: float = 0.0
    """m the printed files' (STL, 3MF) hole faces move out by, a printer's measured hole
    error (`sample --print-offset MM`); the simulation files keep the exact clearance. In
    (-c, c] for the finest clearance c: past it the printed peg would not fit, or the gap
    would close. 0: the printed files are the simulation's geometry."""

    def validate(self) -> DatasetSpec:
        """Every field of the right type and within its bounds (the formats' names are
        checked against the exporters where they are written: assetgen.dataset.generate)."""
        if not isinstance(self.name, str):
            raise DatasetError(f"name = {self.name!r} must be a string")
        if not isinstance(self.formats, tuple) or not all(
            isinstance(f, str) and f for f in self.formats
        ):
            raise DatasetError(
                f"formats = {self.formats!r} must be a list of format names, e.g. ['mjcf', 'usd']"
            )
        if isinstance(self.count, bool) or isinstance(self.seed_start, bool):
            raise DatasetError("count and seed_start are whole numbers, not true/false")
        if not isinstance(self.count, int) or self.count < 1:
            raise DatasetError(f"count = {self.count!r}: a dataset needs at least 1 module")
        if not isinstance(self.seed_start, int) or self.seed_start < 0:
            raise DatasetError(f"seed_start = {self.seed_start!r} must be a non-negative integer")
        try:
            sampler = family(self.family).sampler
        except ValueError as e:
            raise DatasetError(str(e)) from None
        if not isinstance(self.config, sampler):
            raise DatasetError(
                f"config is a {type(self.config).__name__}; family {self.family!r} samples "
                f"with a {sampler.__name__}"
            )
        self.config.validate()
        c = self.config.finest_clearance
        o = self.print_offset
        if not (isinstance(o, int | float) and -c < o <= c):
            raise DatasetError(
                f"print offset {o * 1e3:g} mm: give at most the clearance, {c * 1e3:g} mm (more "
                "and the printed peg would not fit), and more than minus it"
            )
        return self

    @property
    def assembly(self) -> bool:
        """Whether its family builds assemblies (the assembly layout), not Table I modules."""
        from assetgen.families.registry import is_assembly

        return is_assembly(self.family)

    @property
    def seeds(self) -> range:
        return range(self.seed_start, self.seed_start + self.count)

    def to_json(self) -> dict:
        out = {
            "name": self.name,
            "seed_start": self.seed_start,
            "count": self.count,
            "config": self.config.to_json(),
            "formats": list(self.formats),
        }
        if self.family != DEFAULT_FAMILY:  # Table I specs keep their earlier form
            out["family"] = self.family
        if self.print_offset:  # as do specs for the simulation's geometry alone
            out["print_offset_m"] = self.print_offset
        return out

    @staticmethod
    def from_json(d: dict, source: str = "spec") -> DatasetSpec:
        unknown = sorted(set(d) - SPEC_KEYS)
        if unknown:
            raise DatasetError(
                f"{source}: unknown key(s) {unknown}; valid keys: {sorted(SPEC_KEYS)}"
            )
        missing = sorted({"name", "seed_start", "count"} - set(d))
        if missing:
            raise DatasetError(f"{source}: missing key(s) {missing}")
        try:
            fam = family(d.get("family", DEFAULT_FAMILY))
            return DatasetSpec(
                name=d["name"],
                seed_start=d["seed_start"],
                count=d["count"],
                config=fam.sampler.from_json(d.get("config", {})),
                formats=tuple(d.get("formats", DEFAULT_FORMATS)),
                family=fam.name,
                print_offset=d.get("print_offset_m", 0.0),
            ).validate()
        except (ParamError, ValueError) as e:
            raise DatasetError(f"{source}: {e}") from e


def spec_names() -> list[str]:
    return sorted(p.stem for p in SPECS_DIR.glob("*.json"))


def resolve(dataset: str) -> tuple[Path, DatasetSpec | None]:
    """`--dataset` value -> (dataset folder, spec if given by name).

    A name of a spec file in datasets/ (e.g. `train`) maps to datasets/<name>/; anything else
    is taken as the path of a dataset folder.
    """
    spec_file = SPECS_DIR / f"{dataset}.json"
    if "/" not in dataset and spec_file.exists():
        spec = DatasetSpec.from_json(json.loads(spec_file.read_text()), str(spec_file))
        return SPECS_DIR / dataset, spec
    path = Path(dataset)
    if path.exists() or "/" in dataset or dataset.startswith("."):
        return path, None
    raise DatasetError(
        f"no dataset spec named {dataset!r} and no folder {dataset!r}; "
        f"specs: {spec_names()}, or pass the path of a dataset folder"
    )
