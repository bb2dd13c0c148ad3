"""The Blender baseline's own parts (Blender itself is not installed in CI): the shapes it
hands over are Table I's, its script compiles, and a Python without bpy is named."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from assetgen.geometry.solids import cross_section, task_frames
from assetgen.params.sampler import SamplerConfig, sample_params
from benchmarks.blender_baseline import BLENDER_SCRIPT, blender_seconds, table_one_params


def test_the_shapes_are_table_ones():
    params = table_one_params(3)
    for seed, p in enumerate(params):
        m = sample_params(SamplerConfig(), seed)
        assert np.allclose(p["section"], cross_section(m)) and p["taper"] == m.taper
        bottom = np.asarray(p["bottom_matrix"])
        assert np.allclose(bottom, task_frames(m)[1].matrix())
        assert np.allclose(bottom[:3, :3] @ bottom[:3, :3].T, np.eye(3))


def test_the_script_compiles():
    compile(BLENDER_SCRIPT, "generate.py", "exec")


def test_a_python_without_blender_is_named():
    with pytest.raises(SystemExit, match="could not run Blender's side"):
        blender_seconds(sys.executable, table_one_params(1))
