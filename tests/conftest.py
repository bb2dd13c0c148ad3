"""Shared fixtures: a tiny dataset generated once per test session."""

from __future__ import annotations

from pathlib import Path

import pytest

from assetgen.dataset.generate import generate
from assetgen.dataset.spec import DatasetSpec
from assetgen.formats.registry import available_formats
from assetgen.params.sampler import SamplerConfig

TINY_SEEDS = 6


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory) -> Path:
    """Six modules (seeds 0-5) with every registered format."""
    root = tmp_path_factory.mktemp("tiny") / "ds"
    spec = DatasetSpec("tiny", 0, TINY_SEEDS, SamplerConfig(), available_formats())
    summary = generate(root, spec, workers=1, progress=False)
    assert not summary.failures
    return root
