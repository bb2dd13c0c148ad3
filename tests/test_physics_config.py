"""The exported MJCF and the simulator's model carry the same MuJoCo configuration
(assetgen.core.mujoco_config.PhysicsConfig): compile both for the same module and compare."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from assetgen.core.mujoco_config import PhysicsConfig
from sim.scene import build_model
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
)


@pytest.mark.parametrize("index", [0, 1, 2, 3])
def test_exported_file_is_the_training_physics(index: int) -> None:
    asset = modules()[index]
    sim = build_model([asset], PhysicsConfig())
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
