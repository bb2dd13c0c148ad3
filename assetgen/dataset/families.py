"""A family as the dataset stage runs it: the registry's Family (assetgen.families.registry,
assetgen.families.interface) with its layout's writer bound.

`family(name).write(seed, config, modules_dir, formats, times)` writes one module of a seed
through the family's layout: Table I's module writer (assetgen.dataset.module_writer, whose
bytes every earlier dataset holds) or the assembly writer (assetgen.dataset.assembly_writer)
for every family that builds an Assembly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from assetgen.core.references import load_reference
from assetgen.core.timing import StepTimes
from assetgen.families.interface import Family
from assetgen.families.registry import DEFAULT_FAMILY, get

if TYPE_CHECKING:
    from assetgen.families.parts import Assembly

__all__ = ["DEFAULT_FAMILY", "FamilyWriter", "family"]


@dataclass(frozen=True)
class FamilyWriter:
    """`spec`, the Family, with what the dataset stage does with it: write a seed's module,
    read a written module's clearances, rebuild the parts a module was made from."""

    spec: Family

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def sampler(self) -> type:
        """The family's sampler config class (a dataset's dataset.json stores one)."""
        return self.spec.sampler

    def write(
        self,
        seed: int,
        config,
        modules_dir: Path,
        formats: tuple[str, ...],
        times: StepTimes | None = None,
        print_offset: float = 0.0,
    ) -> dict:
        """Write module `seed` under `config` into modules_dir/<id>/ and return its
        module.json; ModuleFailure (nothing written) when it cannot be built or fails a
        check. `formats` are Table I's exporters (an assembly writes all of its files);
        print_offset: m the printed files' hole faces move out by (DatasetSpec's)."""
        writer = load_reference(self.spec.layout.writer)
        if self.spec.layout.name == "module":
            return writer(seed, config, modules_dir, formats, times, print_offset)
        from assetgen.dataset.module_writer import ModuleFailure
        from assetgen.params.module_params import ParamError

        try:
            params = config.sample(seed)
            assembly = self.spec.build(params)
        except ParamError as e:
            raise ModuleFailure(seed, str(e)) from e
        return writer(self.spec.name, params, assembly, seed, modules_dir, times, print_offset)

    def gaps(self, record: dict) -> list[float]:
        """The measured clearances (m) of a written module, from its module.json."""
        if self.spec.layout.name == "module":
            return [record["checks"]["clearance_m"]]
        return [s["clearance_m"] for s in record["checks"]["steps"]]

    @property
    def rebuild(self) -> Callable[[dict], Assembly] | None:
        """params JSON -> the Assembly a module was made from (`assetgen check` compares the
        files with it); None for Table I modules, which are checked by their own rules."""
        if self.spec.layout.name == "module":
            return None
        return lambda params: self.spec.build(self.spec.params.from_json(params))


def family(name: str) -> FamilyWriter:
    """The family called `name`; ValueError listing the valid names otherwise."""
    return FamilyWriter(get(name))
