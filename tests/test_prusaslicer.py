"""The assemblies' 3MF in a slicer: PrusaSlicer (its command line, where installed; CI
installs Debian's) reads every part as its own closed object and slices them as separate
objects."""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import replace

import pytest

from assetgen.dataset.assembly_writer import write_assembly
from assetgen.families.profile_bolt import ProfileBoltSampler, build_profile_bolt

SLICER = shutil.which("prusa-slicer")
pytestmark = pytest.mark.skipif(SLICER is None, reason="PrusaSlicer is not installed")


@pytest.mark.parametrize("slots", [True, False])
def test_the_parts_slice_as_separate_closed_objects(tmp_path, slots) -> None:
    params = replace(ProfileBoltSampler().sample(3), slots=slots)
    write_assembly("profile-bolt", params, build_profile_bolt(params), 3, tmp_path)
    three_mf = tmp_path / "000003" / "assembly.3mf"
    info = subprocess.run([SLICER, "--info", str(three_mf)], capture_output=True, text=True,
                          timeout=300, check=True).stdout  # fmt: skip
    assert info.count("manifold = yes") == 3 and "manifold = no" not in info, info
    assert re.findall(r"number_of_parts =\s+(\d+)", info) == ["1", "1", "1"]
    gcode = tmp_path / "out.gcode"
    subprocess.run([SLICER, "--export-gcode", "--gcode-label-objects", "--output", str(gcode),
                    str(three_mf)], capture_output=True, text=True, timeout=600,
                   check=True)  # fmt: skip
    printed = set(re.findall(r"^; printing object (\w+) ", gcode.read_text(), re.M))
    assert printed == {"base", "profile", "bolt"}


def _slices_as(three_mf, names: set[str], tmp_path) -> None:
    info = subprocess.run([SLICER, "--info", str(three_mf)], capture_output=True, text=True,
                          timeout=300, check=True).stdout  # fmt: skip
    assert info.count("manifold = yes") == len(names) and "manifold = no" not in info, info
    gcode = tmp_path / "out.gcode"
    subprocess.run([SLICER, "--export-gcode", "--gcode-label-objects", "--output", str(gcode),
                    str(three_mf)], capture_output=True, text=True, timeout=600,
                   check=True)  # fmt: skip
    assert set(re.findall(r"^; printing object (\w+) ", gcode.read_text(), re.M)) == names


def test_a_non_convex_peg_and_its_plate_slice(tmp_path) -> None:
    from assetgen.families.profile import ProfileSampler, build_profile

    params = ProfileSampler(shapes=("star",)).sample(1)
    write_assembly("profile", params, build_profile(params), 1, tmp_path)
    _slices_as(tmp_path / "000001" / "assembly.3mf", {"base", "peg"}, tmp_path)


def test_the_clearance_gauge_slices(tmp_path) -> None:
    from assetgen.printing.gauge import GaugeParams, build_gauge

    params = GaugeParams(clearances=(1e-4, 1e-3))
    write_assembly("gauge", params, build_gauge(params), 0, tmp_path)
    _slices_as(tmp_path / "000000" / "assembly.3mf", {"base", "peg_01", "peg_02"}, tmp_path)
