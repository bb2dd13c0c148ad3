"""The exported MJCF and the simulator's model carry the same MuJoCo configuration
(assetgen.core.mujoco_config.PhysicsConfig): compile both for the same module and compare."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from assetgen.core.mujoco_config import PhysicsConfig, physics_for
from sim.engines.mujoco.scene import build_model
from tests.test_sim_common import modules, sim_dataset

OPT_FIELDS = (
    "timestep",
    "gravity",
    "integrator",
    "solver",
    "iterations",
    "cone",
    "impratio",
    "noslip_iterations",
    "disableflags",
    "enableflags",
    "tolerance",
    "ls_tolerance",
    "ccd_iterations",
    "ccd_tolerance",
)


@pytest.mark.parametrize("index", [0, 1, 2, 3])
def test_exported_file_is_the_training_physics(index: int) -> None:
    asset = modules()[index]
    sim = build_model([asset], physics_for(asset.clearance))
    exported = mujoco.MjModel.from_xml_path(
        str(sim_dataset() / "modules" / asset.id / "peg_in_hole.xml")
    )
    for f in OPT_FIELDS:
        np.testing.assert_array_equal(getattr(sim.opt, f), getattr(exported.opt, f), err_msg=f)
    gs, ge = sim.geom("peg").id, exported.geom("peg").id
    for f in (
        "geom_solref",
        "geom_solimp",
        "geom_friction",
        "geom_condim",
        "geom_margin",
        "geom_gap",
        "geom_priority",
    ):
        np.testing.assert_allclose(getattr(sim, f)[gs], getattr(exported, f)[ge], err_msg=f)
    # the module pieces' own contact parameters lose to the peg's (priority / max friction)
    assert sim.nu == exported.nu == 6
    for f in (
        "actuator_gainprm",
        "actuator_biasprm",
        "actuator_gear",
        "actuator_trntype",
        "actuator_gaintype",
        "actuator_biastype",
        "actuator_ctrllimited",
        "actuator_forcelimited",
    ):
        # module.json rounds the inertia the simulator reads: gains agree to ~1e-9
        np.testing.assert_allclose(getattr(sim, f), getattr(exported, f), rtol=1e-6, err_msg=f)
    ps, pe = sim.body("peg").id, exported.body("peg").id
    np.testing.assert_allclose(sim.body_mass[ps], exported.body_mass[pe])
    np.testing.assert_allclose(sim.body_inertia[ps], exported.body_inertia[pe], rtol=1e-6)


def test_convex_search_settings_reach_file_and_simulator_alike() -> None:
    """ccd_iterations and ccd_tolerance (a benchmark's --set) reach the simulator's model and
    the `<option>` the MJCF writer uses alike; at MuJoCo's defaults the file does not name
    them, so files written before the fields keep their bytes."""
    from dataclasses import replace

    from assetgen.core.mujoco_config import option_xml

    asset = modules()[0]
    default = physics_for(asset.clearance)
    assert "ccd_" not in "".join(option_xml(default))
    physics = replace(default, ccd_iterations=200, ccd_tolerance=1e-9).validate()
    sim = build_model([asset], physics)
    doc = "<mujoco>" + "".join(option_xml(physics)) + "</mujoco>"
    exported = mujoco.MjModel.from_xml_string(doc)
    assert sim.opt.ccd_iterations == exported.opt.ccd_iterations == 200
    assert sim.opt.ccd_tolerance == exported.opt.ccd_tolerance == 1e-9
    with pytest.raises(ValueError, match=r"ccd_tolerance = 0\.0: give a positive length"):
        replace(default, ccd_tolerance=0.0).validate()


PINNED = {
    "version": 2,
    "timestep": 0.0005,
    "substeps": 40,
    "contact_timeconst": 0.001,
    "dampratio": 5.0,
    "min_dampratio": 4.0,
    "impratio": 100.0,
    "solimp": [0.99, 0.9999, 0.0005, 0.5, 2.0],
    "iterations": 30,
    "integrator": "discrete",
}
"""The settings of PHYSICS_VERSION as the contact stress benchmark chose them (docs/physics.md):
a change to any of them without a new version fails here, so no dataset's files claim
physics they do not carry."""


def test_physics_version_pins_the_settings() -> None:
    from assetgen.core.mujoco_config import physics_record

    record = physics_record(physics_for(1e-3))
    assert {k: record[k] for k in PINNED} == PINNED


def test_dataset_records_its_physics_and_the_simulator_refuses_others(tmp_path) -> None:
    """dataset.json and every MJCF name the physics version; a dataset of another version is
    refused with a message that says how to regenerate it or keep its physics, and kept on
    request with the physics its record holds."""
    import json
    import shutil

    from assetgen.core.mujoco_config import PHYSICS_TEXT, PHYSICS_VERSION
    from sim.assets.loading import AssetError, check_physics
    from sim.env import make_eval_env

    root = tmp_path / "ds"
    shutil.copytree(sim_dataset(), root)
    info = json.loads((root / "dataset.json").read_text())
    assert info["physics"]["version"] == PHYSICS_VERSION
    mid = modules()[0].id
    spec = mujoco.MjSpec.from_file(str(root / "modules" / mid / "peg_in_hole.xml"))
    assert spec.text(PHYSICS_TEXT).data.split()[-1] == str(PHYSICS_VERSION)
    assert check_physics(root) is None

    del info["physics"]  # as generator 0.5.0 wrote it: physics version 1, 5 ms steps
    (root / "dataset.json").write_text(json.dumps(info))
    with pytest.raises(AssetError) as e:
        make_eval_env(str(root), None, 0, modules=1)
    msg = str(e.value)
    assert "version 1" in msg and f"version {PHYSICS_VERSION}" in msg and "5 ms" in msg
    assert "--overwrite" in msg and "keep_physics=True" in msg
    from rl.commands import flag_words  # the command line names its flag instead

    assert "--keep-dataset-physics" in flag_words(msg) and "keep_physics" not in flag_words(msg)
    kept = check_physics(root, keep=True)
    assert kept.timestep == 0.005 and kept.substeps == 4
    env = make_eval_env(str(root), None, 0, modules=1, keep_physics=True)
    assert env.cfg.physics == kept and env.protocol["physics_version"] == 1


def test_validate_names_a_value_that_works() -> None:
    works = r"use contact_timeconst >= 0.001 \(or timestep <= 0.0005\)"
    with pytest.raises(ValueError, match=works):
        PhysicsConfig(timestep=0.001, contact_timeconst=0.0005).validate()
    with pytest.raises(ValueError, match=r"min_dampratio = 6.0, dampratio = 5.0"):
        PhysicsConfig(dampratio=5.0, min_dampratio=6.0).validate()
