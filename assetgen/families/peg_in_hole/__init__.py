"""The `peg-in-hole` family: the paper's Table I, a convex peg and a plate with its hole.

Its pieces live in assetgen's stages, as they were before families existed: parameters in
assetgen/params (ModuleParams, SamplerConfig), the solids in assetgen/geometry/solids.py,
and the module layout's checks, collision pieces, writers, simulator loading and preview
(assetgen.families.interface.MODULE). Its files are byte for byte the ones every earlier
dataset holds.
"""

from __future__ import annotations

from assetgen.families.interface import MODULE, Family
from assetgen.params.module_params import ModuleParams
from assetgen.params.sampler import SamplerConfig


def build(params: ModuleParams):
    """The peg, the module and their frames (assetgen.geometry.solids.build_module, imported
    here: naming the family, as every dataset spec does, loads no CAD library)."""
    from assetgen.geometry.solids import build_module

    return build_module(params)


FAMILY = Family(
    name="peg-in-hole",
    summary="the paper's Table I: a convex peg (n-gon or circle, tapered) and a plate with "
    "its tilted hole",
    sampler=SamplerConfig,
    params=ModuleParams,
    build=build,
    layout=MODULE,
)
"""The family (assetgen.families.interface); its modules take the module layout."""
