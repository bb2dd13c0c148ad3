"""Physics of the batched simulator: the velocity controller and the contacts."""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from assetgen.core.rotations import matrix_to_quat, matrix_to_rotvec, quat_to_matrix
from sim.assets.loading import load_dataset
from sim.engines.mujoco.scene import restitution_to_dampratio
from sim.env import PegInHoleVecEnv
from sim.task.config import PhysicsConfig
from tests.test_sim_common import above_plate, make_env, quiet

# one physics step per env step, so every physics state can be inspected
H = PhysicsConfig().timestep
"""The physics step of a 1 mm module, s."""
FINE = quiet(physics=PhysicsConfig(substeps=1), max_steps=100_000)
STEP_TRAVEL = 0.25 * H  # full speed for one physics step, m


def steps(seconds: float) -> int:
    """Physics steps in `seconds`."""
    return round(seconds / H)


def _free_pose(env, i: int = 0) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = quat_to_matrix(np.array([0.9, 0.2, -0.3, 0.1]))
    pose[:3, 3] = env.entrance[i, :3, 3] + [0.0, 0.0, 0.2]
    return pose


def test_zero_action_keeps_the_peg_still() -> None:
    env = make_env(2)
    env.reset(seed=0)
    env.set_peg_poses(np.arange(2), np.stack([_free_pose(env, 0), _free_pose(env, 1)]))
    before = env.peg_poses()
    for _ in range(50):
        env.step(np.zeros((2, 6)))
    after = env.peg_poses()
    assert np.abs(after[:, :3, 3] - before[:, :3, 3]).max() < 1e-9
    assert np.abs(after[:, :3, :3] - before[:, :3, :3]).max() < 1e-9


@pytest.mark.parametrize("axis", [0, 3])
def test_commanded_velocity_is_tracked(axis: int) -> None:
    """Step response: 90 % within 30 ms, then exact."""
    env = make_env(1, FINE)
    env.reset(seed=0)
    env.set_peg_poses(np.array([0]), _free_pose(env)[None])
    act = np.zeros((1, 6))
    act[0, axis] = 1.0
    target = 0.25 if axis < 3 else np.pi / 2
    site_vel = []
    prev = env.peg_poses()[0]
    for _ in range(steps(0.2)):
        env.step(act)
        now = env.peg_poses()[0]
        if axis < 3:
            v = (now[axis, 3] - prev[axis, 3]) / H
        else:  # angular velocity about module x from the rotation increment
            v = matrix_to_rotvec((now[:3, :3] @ prev[:3, :3].T)[None])[0, 0] / H
        site_vel.append(v / target)
        prev = now
    site_vel = np.array(site_vel)
    rise = int(np.argmax(site_vel >= 0.9)) + 1
    print(f"axis {axis}: response {np.round(site_vel[:: steps(0.005)][:8], 3)}; 90 % after {rise}")
    assert rise <= steps(0.03)
    assert abs(site_vel[-steps(0.05) :].mean() - 1.0) < 0.005
    assert site_vel.max() < 1.1  # no overshoot to speak of


def _kinetic_energy(env) -> float:
    """0.5 qdot^T M(q) qdot of env 0's peg (its model holds that peg alone)."""
    m = env.sim.models[env.sim.shard_of[0]]
    assert m.nv == 6
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = env.sim.state[0, 1:8], env.sim.qvel[0]
    mujoco.mj_forward(m, d)
    mass = np.zeros((6, 6))
    mujoco.mj_fullM(m, d, mass)
    return float(0.5 * d.qvel @ mass @ d.qvel)


@pytest.mark.parametrize("kick", [0, 3])
def test_a_knocked_peg_is_damped(kick: int) -> None:
    """A contact can knock the peg far above the commanded speeds. With zero command the
    controller is a pure damper: it takes energy out at every step (free in space, where
    nothing else acts)."""
    env = make_env(1, FINE)
    env.reset(seed=0)
    env.set_peg_poses(np.array([0]), _free_pose(env)[None])
    env.sim.qvel[0] = 0.0
    env.sim.qvel[0, kick : kick + 3] = [10.0, -5.0, 3.0] if kick == 0 else [20.0, -12.0, 6.0]
    energy = [_kinetic_energy(env)]
    for _ in range(steps(0.2)):
        env.step(np.zeros((1, 6)))
        energy.append(_kinetic_energy(env))
    assert np.all(np.diff(energy) <= 1e-12 * energy[0]), np.round(energy, 6)
    assert energy[-1] < 1e-6 * energy[0]


def test_a_spinning_peg_under_full_command_is_not_spun_up(tmp_path) -> None:
    """Test-split module 003014 (a peg with a small inertia about its axis), knocked to
    24 rad/s about that axis (seen after a contact in training) while a policy commands near
    full speed. Force-clamped actuators, whose damping MuJoCo still integrated implicitly,
    spun it up a billion-fold in energy (and such pegs flew off at km/s, polluting training
    batches); unclamped, the energy stays within a small factor of the start's and of the
    commanded motion's."""
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.params.sampler import SamplerConfig

    spec = DatasetSpec("spin", 3014, 1, SamplerConfig(), ("collision",))
    assert not generate(tmp_path / "spin", spec, workers=1, progress=False).failures
    env = PegInHoleVecEnv(load_dataset(tmp_path / "spin"), config=FINE, nthread=1)
    env.reset(seed=0)
    env.set_peg_poses(np.array([0]), _free_pose(env)[None])
    env.sim.qvel[0] = [0.0, 0.0, 0.0, 0.0, 0.0, 24.0]
    energy = [_kinetic_energy(env)]
    for _ in range(steps(0.2)):
        env.step(np.array([[0.5, -0.9, 0.7, 0.95, -1.0, -1.0]]))
        energy.append(_kinetic_energy(env))
    assert max(energy) < 3.0 * max(energy[0], energy[-1]), np.round(energy, 4)


def test_rotation_is_about_the_bottom_face_centre() -> None:
    env = make_env(1)
    env.reset(seed=0)
    start = _free_pose(env)
    env.set_peg_poses(np.array([0]), start[None])
    for _ in range(25):  # 0.5 s at 90 deg/s about module y
        env.step(np.array([[0, 0, 0, 0, 1.0, 0]]))
    end = env.peg_poses()[0]
    turned = matrix_to_rotvec((end[:3, :3] @ start[:3, :3].T)[None])[0]
    drift = np.linalg.norm(end[:3, 3] - start[:3, 3])
    print(f"turned {np.degrees(turned)} deg; bottom-face centre moved {drift * 1e3:.3f} mm")
    assert abs(np.degrees(turned[1]) - 45.0) < 1.5
    assert np.abs(np.degrees(turned[[0, 2]])).max() < 0.5
    assert drift < 0.5e-3


def _min_distance(env, i: int = 0) -> float:
    dist, _ = env.sim.contacts(i)
    return float(dist.min()) if len(dist) else np.inf


def _put(env, i: int, pose: np.ndarray) -> None:
    """Place env i's peg at rest (physics only: no episode, so no success or failure)."""
    env.sim.set_pose(np.array([i]), pose[None, :3, 3], matrix_to_quat(pose[None, :3, :3]))


def _drive(env, action: np.ndarray, steps: int, i: int = 0) -> tuple[float, float]:
    """Command action (6,) (in [-1, 1]) to env i for `steps` physics steps, straight on the
    simulator; the deepest penetration over the run and at its end, m (>= 0)."""
    scale = np.array([0.25] * 3 + [np.pi / 2] * 3)
    velocity = np.zeros((env.num_envs, 6))
    velocity[i] = action * scale
    deepest = 0.0
    for _ in range(steps):
        assert not env.sim.step(velocity).any()
        deepest = max(deepest, -_min_distance(env, i))
    return deepest, max(0.0, -_min_distance(env, i))


def test_full_speed_into_the_plate_never_passes_through() -> None:
    env = make_env(1, FINE)
    env.reset(seed=0)
    _put(env, 0, above_plate(env, 0, 0.0101))
    deepest, held = _drive(env, np.array([0, 0, -1.0, 0, 0, 0]), steps(1.25))
    z = env.peg_poses()[0, 2, 3]
    print(f"plate: transient {deepest * 1e3:.3f} mm, held at full force {held * 1e6:.2f} um")
    assert deepest < STEP_TRAVEL
    assert held < 1e-4
    assert z > -1e-4  # resting on the surface, not through it


def _side_normal(env, i: int) -> np.ndarray:
    """Module-frame normal of the seated peg's largest side face (the hole wall facing it
    is parallel to it, 1 mm away)."""
    v = env.modules[env.env_module[i]].peg.vertices
    f = env.modules[env.env_module[i]].peg.faces
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = np.linalg.norm(n, axis=1)
    side = np.abs(n[:, 2]) < 0.3 * area  # faces along the axis (tapered up to 25 %)
    k = np.flatnonzero(side)[np.argmax(area[side])]
    return env.bottom[i, :3, :3] @ (n[k] / area[k])


@pytest.mark.parametrize("module", [0, 1])
def test_full_speed_into_a_hole_wall_never_passes_through(module: int) -> None:
    env = make_env(module + 1, FINE)
    env.reset(seed=0)
    inside = env.bottom[module].copy()
    inside[:3, 3] += 0.002 * inside[:3, 2]  # 2 mm above the floor: walls all round
    _put(env, module, inside)
    push = np.zeros(6)
    push[:3] = _side_normal(env, module)
    deepest, held = _drive(env, push, steps(1.25), module)
    moved = np.linalg.norm(env.peg_poses()[module, :3, 3] - inside[:3, 3])
    print(f"wall: transient {deepest * 1e3:.3f} mm, held {held * 1e6:.2f} um")
    print(f"      the bottom-face centre moved {moved * 1e3:.3f} mm")
    assert deepest < STEP_TRAVEL
    assert held < 1e-4
    assert moved < 0.0015  # the 1 mm clearance, then the wall


def test_restitution_maps_onto_damping_ratio() -> None:
    p = PhysicsConfig(dampratio=5.0, min_dampratio=4.0)
    z = restitution_to_dampratio(np.array([0.0, 0.5, 1.0]), p)
    assert z.tolist() == pytest.approx([5.0, 4.5, 4.0])


@pytest.mark.parametrize("restitution", [0.0, 1.0])
def test_pushed_peg_settles_on_the_plate(restitution: float) -> None:
    """The whole restitution range stays free of a chatter limit cycle."""
    cfg = replace(FINE, restitution_range=(restitution, restitution))
    env = make_env(1, cfg)
    env.reset(seed=0)
    _put(env, 0, above_plate(env, 0, 0.0101))
    down = np.array([0, 0, -1.0, 0, 0, 0])
    _drive(env, down, steps(1.0))
    depth = []
    for _ in range(steps(0.25)):
        _drive(env, down, 1)
        depth.append(-_min_distance(env))
    assert min(depth) >= 0.0  # in contact at every step: no bouncing
    assert max(depth) < 1e-4


def test_contact_parameters_follow_the_reset_draws() -> None:
    env = make_env(2, replace(quiet(), friction_range=(0.3, 0.3), restitution_range=(0.0, 0.0)))
    env.reset(seed=0)
    for i in range(2):
        m = env.sim.models[env.sim.shard_of[i]]
        g = env.sim.peg_geom[i]
        assert m.geom_friction[g, 0] == pytest.approx(0.3)
        p = env.cfg.physics
        assert m.geom_solref[g, 1] == pytest.approx(p.dampratio)  # e = 0: the nominal ratio
        assert m.geom_solref[g, 0] * m.geom_solref[g, 1] == pytest.approx(p.contact_timeconst)


def test_batched_rollout_matches_stepping_each_env_alone() -> None:
    """Modules of different sizes share the per-thread MjData of the capacity model; the
    result must be bit-for-bit what each env's own MjData gives."""
    import mujoco
    from mujoco import rollout

    from sim.env import PegInHoleVecEnv
    from tests.test_sim_common import modules

    env = PegInHoleVecEnv(list(modules()) * 2, 8, quiet(), nthread=2, shard_size=1)
    env.reset(seed=0)
    assert len({m.ngeom for m in env.sim.models}) > 1  # really heterogeneous
    for i in range(8):  # just above the plate: the run is full of contacts
        _put(env, i, above_plate(env, i, 0.003))
    start = env.sim.state.copy()
    rng = np.random.default_rng(0)
    vel = [rng.uniform(-0.25, 0.25, (8, 6)) * [0.2, 0.2, 0, 0.1, 0.1, 1] for _ in range(20)]
    for v in vel:
        v[:, 2] = -0.1
        env.sim.step(v)
    # pressed on the plate while rocking: most pegs touch it at the end
    assert sum(_min_distance(env, i) < 0 for i in range(8)) >= 6
    batched = env.sim.state.copy()
    n = env.cfg.physics.substeps
    for i, m in enumerate(env.sim.models):
        state = start[i : i + 1].copy()
        data = mujoco.MjData(m)
        for v in vel:
            ctrl = np.repeat(v[i][None, None], n, axis=1)
            out, _ = rollout.rollout(m, data, state, ctrl, nstep=n)
            state = out[:, -1]
        assert np.array_equal(state[0], batched[i])


def test_shards_simulate_each_env_as_if_alone() -> None:
    """Envs sharing a model (and a phantom slot filling the last shard) move as with a model
    each: no cross-talk between the modules of a shard. Not bit for bit: the constraint
    solver stops on the whole shard's residual, so results agree to its tolerance."""
    runs = []
    for shard_size in (1, 2):
        env = make_env(3, quiet(), shard_size=shard_size)
        env.reset(seed=0)
        for i in range(3):
            _put(env, i, above_plate(env, i, 0.003))
        rng = np.random.default_rng(1)
        touching = np.zeros(3)
        # 0.24 s: pressed while turning at random, the pegs rock on their edges; later, a
        # contact made or lost a solver tolerance apart sends the two runs apart
        for _ in range(12):
            v = rng.uniform(-0.05, 0.05, (3, 6))
            v[:, 2] = -0.05  # pressed on the plate: contacts all along
            assert not env.sim.step(v).any()
            touching += [_min_distance(env, i) < 0 for i in range(3)]
        assert touching.min() >= 1 and touching.sum() >= 12, touching
        runs.append(env.sim.state.copy())
    diff = np.abs(runs[0] - runs[1])
    assert diff[:, 1:8].max() < 1e-6  # poses: within a micrometre (1e-6 in quaternion)
    assert diff[:, 8:].max() < 1e-3  # velocities
    assert diff[2].max() < 1e-12  # alone in its shard (with a phantom): the same numbers


@pytest.mark.parametrize("mu", [0.0, 0.5, 1.0])
def test_coulomb_friction_on_a_pressed_peg(mu: float) -> None:
    """Pressed down at full command (N = kv x 0.25 m/s) and pushed sideways at full
    command, the peg slides where the controller's force exceeds mu N: at
    v = 0.25 - mu N / kv = 0.25 (1 - mu) m/s by hand (kv cancels)."""
    env = make_env(1, replace(FINE, friction_range=(mu, mu)))
    env.reset(seed=0)
    _put(env, 0, above_plate(env, 0, 0.0005))
    _drive(env, np.array([0, 0, -1.0, 0, 0, 0]), steps(0.2))
    _drive(env, np.array([1.0, 0, -1.0, 0, 0, 0]), steps(0.3))  # let the sliding settle
    x0 = env.sim.peg_pos[0, 0]
    _drive(env, np.array([1.0, 0, -1.0, 0, 0, 0]), steps(0.1))
    speed = (env.sim.peg_pos[0, 0] - x0) / (steps(0.1) * H)
    assert speed == pytest.approx(0.25 * (1 - mu), abs=0.006)
