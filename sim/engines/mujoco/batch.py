"""Many environments stepped together in C threads with `mujoco.rollout`.

Envs are grouped in shards: `shard_size` modules and their pegs side by side in one MjModel
(each peg collides only with its own module, through its own collision bit), each shard
stepped `substeps` physics steps per call with no Python in between, the shards spread over
C threads by `mujoco.rollout`. Friction and restitution are randomised per env in its
shard's model. Why shards (measured with `assetgen bench sim --shard-size`): in free flight the
per-step overhead is shared by the pegs of a shard, and a thread pool of `mj_step` calls is
bound by the GIL between the short C calls. The price of sharing: MuJoCo stops stepping a
model after a warning, so an unstable env stalls its shard-mates for that step (they are
reported too).

`rollout` reuses one MjData per thread across models, so every MjData array sized by the
model must be large enough for each of them. Our models differ only in geometry counts
(geoms, meshes, BVH nodes), so the per-thread MjData are made from a *capacity model* whose
every data-sizing count is at least every shard's (checked in `check_capacity`); the rest
(nq, nv, nu, ...) is equal by construction (phantom slots fill the last shard).
"""

from __future__ import annotations

import copy
import os
from collections.abc import Callable

import mujoco
import numpy as np
from mujoco import rollout

from sim.assets.loading import ModuleAsset
from sim.engines.base import EngineOptions, EngineSim
from sim.engines.mujoco.scene import (
    build_model,
    contact_solref,
    geom_contacts,
    restitution_to_dampratio,
)
from sim.task import kernel as K
from sim.task.config import TaskConfig

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS
# Counts that size arrays of mjData: the capacity model's must be at least each model's.
_GROWING_SIZES = ("ngeom", "nbvh", "nbvhstatic", "nbvhdynamic")
# Counts that size nothing in mjData: model arrays, or scratch that the collision code takes
# from the arena at run time by the stepping model's own count (npolygonmax, nmeshdegmax:
# convex-collision buffers). Every other n* count must be equal across models.
_NOT_DATA_SIZES = (
    "nmesh", "nmeshvert", "nmeshnormal", "nmeshtexcoord", "nmeshface", "nmeshgraph",
    "nmeshpoly", "nmeshpolyvert", "nmeshpolymap", "nnames", "nnames_map", "npaths",
    "ntext", "ntextdata", "nbuffer", "npolygonmax", "nmeshdegmax",
)  # fmt: skip


def _sizes(m: mujoco.MjModel) -> dict[str, int]:
    return {
        n: getattr(m, n)
        for n in dir(m)
        if n.startswith("n") and isinstance(getattr(m, n), int) and n not in _NOT_DATA_SIZES
    }


def check_capacity(capacity: mujoco.MjModel, models: list[mujoco.MjModel]) -> None:
    """Raise ValueError unless an MjData of `capacity` can step every model in `models`."""
    ref = _sizes(capacity)
    for m in models:
        for k, v in _sizes(m).items():
            if k in _GROWING_SIZES:
                if v > ref[k]:
                    raise ValueError(f"rollout capacity: {k} = {v} exceeds {ref[k]}")
            elif v != ref[k]:
                raise ValueError(f"rollout needs equal model sizes; {k}: {v} != {ref[k]}")


def shard_layout(num_envs: int, shard_size: int) -> tuple[int, int]:
    """(shards, slots per shard) for `num_envs` envs in shards of at most `shard_size`;
    the last shard is filled up with phantom slots so that every model has equal sizes."""
    k = max(1, min(shard_size, num_envs, 31))  # 31: one collision bit per slot
    return -(-num_envs // k), k


class BatchSim(EngineSim):
    """`num_envs` peg-in-hole scenes; state is (num_envs, nstate) = [time, qpos(7), qvel(6)].

    qpos of the free joint is the peg frame's pose in the module frame: position (3),
    quaternion (w, x, y, z). qvel is the linear velocity of that origin (module frame) and
    the angular velocity (peg frame), as MuJoCo defines a free joint's velocity.

    `shard_size` envs share one MjModel (side by side, `SPACING` m apart, each peg colliding
    only with its own module through its own collision bit); 1 gives one model per env.
    Each env's state is gathered from and scattered to its shard's state with index arrays.
    """

    SPACING = 2.0
    """Distance between neighbouring envs of a shard, m (beyond any peg's reach of its
    module: contacts are filtered by collision bits anyway)."""

    def __init__(
        self,
        env_assets: list[ModuleAsset],
        task: TaskConfig,
        nthread: int | None = None,
        shard_size: int = 8,
        spare_assets: list[ModuleAsset] | None = None,
    ) -> None:
        self.task = task
        self.num_envs = n = len(env_assets)
        p = task.physics
        s_count, k = shard_layout(n, shard_size)
        self.shard_size = k
        # phantom slots repeat the last module; they are stepped at rest and never read
        slots = list(env_assets) + [env_assets[-1]] * (s_count * k - n)
        groups = [slots[i * k : (i + 1) * k] for i in range(s_count)]

        def build(assets: list[ModuleAsset], pad: int = 0) -> mujoco.MjModel:
            return build_model(
                assets,
                p,
                max_lin_vel=task.max_lin_vel,
                max_ang_vel=task.max_ang_vel,
                spacing=self.SPACING,
                pad_geoms=pad,
            )

        if spare_assets and k != 1:
            raise ValueError("spare modules (set_module) need one model per env: shard_size=1")
        self.pool: dict[str, mujoco.MjModel] = {}
        """Module id -> its model, for every module given (one model per env only)."""
        if k == 1:
            # one model per module, copied per env: friction and restitution are randomised
            # per env, in the model
            built = self.pool
            for a in list(env_assets) + list(spare_assets or ()):
                if a.id not in built:
                    built[a.id] = build([a])
            self.models = [copy.copy(built[g[0].id]) for g in groups]
            distinct = list(built.values())
            group_of = {a.id: [a] for a in list(env_assets) + list(spare_assets or ())}
            key_of = {id(m): mid for mid, m in built.items()}
        else:
            self.models = [build(g) for g in groups]
            distinct = self.models
            group_of = {str(i): g for i, g in enumerate(groups)}
            key_of = {id(m): str(i) for i, m in enumerate(self.models)}
        names = ["peg"] if k == 1 else [f"e{j}_peg" for j in range(k)]
        bodies = [self.models[e // k].body(names[e % k]) for e in range(n)]
        self.peg_geom = np.array([int(b.geomadr[0]) for b in bodies])
        """Per env: the id of its peg's first geom (a peg that is not convex has several,
        with consecutive ids)."""
        self.peg_ngeom = np.array([int(b.geomnum[0]) for b in bodies])
        """Per env: how many geoms its peg has."""

        # the per-thread MjData: from the model with the most BVH nodes, padded with inert
        # geoms up to the largest geom count
        big = max(distinct, key=lambda m: (m.nbvh, m.ngeom))
        pad = max(m.ngeom for m in distinct) - big.ngeom
        capacity = build(group_of[key_of[id(big)]], pad) if pad > 0 else big
        check_capacity(capacity, distinct)
        self.nthread = max(1, nthread if nthread is not None else os.cpu_count() or 1)
        self.datas = [mujoco.MjData(capacity) for _ in range(self.nthread)]
        self._rollout = rollout.Rollout(nthread=self.nthread if self.nthread > 1 else 0)
        self._scratch = mujoco.MjData(capacity)

        # index arrays: env e lives in shard e // k, slot e % k
        env = np.arange(n)
        slot = env % k
        self.shard_of = env // k
        self._qpos_idx = 1 + 7 * slot[:, None] + np.arange(7)
        self._qvel_idx = 1 + 7 * k + 6 * slot[:, None] + np.arange(6)
        self.nstate = 14
        nshard = mujoco.mj_stateSize(self.models[0], STATE_SPEC)
        # env state [time, qpos, qvel] <-> flat positions in shard_state.ravel(): one take /
        # put per step instead of three 2-D fancy indexings (the env layer's per-step cost is
        # what `assetgen bench sim` compares against raw rollout)
        cols = np.concatenate([np.zeros((n, 1), int), self._qpos_idx, self._qvel_idx], axis=1)
        self._flat = self.shard_of[:, None] * nshard + cols
        self._offset = np.zeros((n, self.nstate))
        self._offset[:, 1] = slot * self.SPACING
        self.shard_state = np.zeros((s_count, nshard))
        self.shard_state[:, 1 : 1 + 7 * k].reshape(s_count, k, 7)[:, :, 3] = 1.0
        all_slots = np.arange(s_count * k) % k
        self.shard_state[:, 1 : 1 + 7 * k].reshape(s_count, k, 7)[:, :, 0] = (
            all_slots.reshape(s_count, k) * self.SPACING
        )
        self.state = np.zeros((n, self.nstate))
        self._ss_flat = self.shard_state.reshape(-1)  # a view: shard_state is contiguous
        self.gather()
        self.substeps = p.substeps
        self._out = np.empty((s_count, p.substeps, nshard))
        self._ctrl = np.zeros((s_count, p.substeps, 6 * k))
        # env e = shard * k + slot: its 6 controls are entries 6e .. 6e + 5 of the shards'
        # first-substep controls laid end to end (phantom slots, at the end, stay zero)
        self._ctrl0 = np.zeros((s_count, 6 * k))

        self._layout = K.Layout(flat=self._flat, offset=self._offset, shard_of=self.shard_of)
        self._checks = K.Checks.of(p)

    # ------------------------------------------------------------------ layout

    def gather(self) -> None:
        """Per-env state from the shard states (positions back into each module frame)."""
        np.subtract(self._ss_flat.take(self._flat), self._offset, out=self.state)

    def _scatter(self) -> None:
        # time is written back too: every env of a shard holds its shard's time
        self._ss_flat[self._flat] = self.state + self._offset

    def shard_state_now(self) -> np.ndarray:
        """A copy of the shard states holding every env's latest state. `set_pose` (a reset)
        writes the per-env state only, which the shards take at the next step: a state saved
        right after a step that reset an env must scatter it first, or a resume would put
        that env's peg back where its last episode ended."""
        self._scatter()
        return self.shard_state.copy()

    # ------------------------------------------------------------------ state access

    def set_contact(self, idx: np.ndarray, friction: np.ndarray, dampratio: np.ndarray) -> None:
        """Peg-module contact of envs `idx`: Coulomb friction (k,) and damping ratio (k,).

        The peg geom has priority over the module pieces, so its values are the contact's.
        """
        solref = contact_solref(dampratio, self.task.physics)
        for j, e in enumerate(np.asarray(idx)):
            m = self.models[self.shard_of[e]]
            g = slice(self.peg_geom[e], self.peg_geom[e] + self.peg_ngeom[e])
            m.geom_friction[g, 0] = friction[j]
            m.geom_solref[g] = solref[j]

    def set_material(
        self, idx: np.ndarray, static: np.ndarray, dynamic: np.ndarray, restitution: np.ndarray
    ) -> None:
        """The task's contact draws for envs `idx`, as MuJoCo models contact: one Coulomb
        coefficient, the dynamic one (it governs sliding, the regime of insertion; the static
        draw is unused), and restitution mapped onto the damping ratio
        (scene.restitution_to_dampratio)."""
        del static
        self.set_contact(idx, dynamic, restitution_to_dampratio(restitution, self.task.physics))

    def contact_params(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-env peg friction (num_envs,) and solref (num_envs, 2), as set last."""
        fr = np.array([self.models[s].geom_friction[g, 0] for s, g in self._peg_refs()])
        sr = np.array([self.models[s].geom_solref[g] for s, g in self._peg_refs()])
        return fr, sr

    def set_contact_params(self, friction: np.ndarray, solref: np.ndarray) -> None:
        """Restore what `contact_params` returned."""
        for e, (s, g) in enumerate(self._peg_refs()):
            geoms = slice(g, g + self.peg_ngeom[e])
            self.models[s].geom_friction[geoms, 0] = friction[e]
            self.models[s].geom_solref[geoms] = solref[e]

    def _peg_refs(self) -> list[tuple[int, int]]:
        return list(zip(self.shard_of.tolist(), self.peg_geom.tolist(), strict=True))

    def set_module(self, e: int, module_id: str) -> None:
        """Put env `e` on module `module_id` (one given at construction; one model per env).

        The env gets its own copy of the module's model (friction and restitution are the
        env's), so two envs may share a module. Its state (same sizes in every model) is
        kept: place the peg with `set_pose` and set its contact with `set_contact` next."""
        if self.shard_size != 1:
            raise ValueError("set_module needs one model per env (shard_size=1)")
        if module_id not in self.pool:
            raise ValueError(f"module {module_id!r} was not given to this BatchSim")
        m = copy.copy(self.pool[module_id])
        self.models[e] = m
        self.peg_geom[e] = int(m.body("peg").geomadr[0])
        self.peg_ngeom[e] = int(m.body("peg").geomnum[0])

    # ------------------------------------------------------------------ stepping

    saves_state = True
    parks_idle = True
    """`step(velocity, live)` leaves the shards without a live env unstepped (set_live)."""

    @classmethod
    def create(cls, env_assets, task, spare_assets, options: EngineOptions) -> BatchSim:
        return cls(env_assets, task, options.nthread, options.shard_size, spare_assets)

    def step(self, velocity: np.ndarray, live: np.ndarray | None = None) -> np.ndarray:
        """Advance every env by one control step at the commanded velocity.

        velocity: (num_envs, 6) target linear (m/s) and angular (rad/s) velocity of the peg's
        bottom-face centre in the module frame. live: (num_envs,) bool or None (all): a shard
        none of whose envs is live is not stepped (its states, time included, stay as they
        were, and its envs are not flagged). Returns (num_envs,) bool: envs whose
        physics broke down: a non-finite state, or a shard that MuJoCo stopped stepping
        after a warning (seen as a time that did not advance; every env of it is flagged,
        as none of them moved), or a runaway peg (faster than `runaway_speed`).
        """
        # the layout work (scatter, gather, checks) is compiled: it runs on one thread
        # between the rollout calls
        K.scatter(self.state, self._layout, velocity, self._ss_flat, self._ctrl)
        t0 = self.shard_state[:, 0].copy()
        busy = None
        if live is not None and not live.all():
            busy = np.zeros(len(self.models), dtype=bool)
            busy[self.shard_of[live]] = True
        # every shard (views, no copies), or an evaluation's tail: the shards that still hold
        # counted episodes
        idx = slice(None) if busy is None or busy.all() else np.flatnonzero(busy)
        models = self.models if isinstance(idx, slice) else [self.models[i] for i in idx]
        if models:
            out = self._out[: len(models)]
            self._rollout.rollout(
                models,
                self.datas,
                self.shard_state[idx],
                self._ctrl[idx],
                nstep=self.task.physics.substeps,
                state=out,
                skip_checks=True,
            )
            self.shard_state[idx] = out[:, -1]
        unstable = np.empty(self.num_envs, dtype=bool)
        K.gather(self._ss_flat, self._layout, t0, self._checks, self.state, unstable)
        if busy is not None:
            unstable &= busy[self.shard_of]  # an unstepped shard's time did not advance
        return unstable

    def raw_round(self, velocities: list[np.ndarray]) -> Callable[[], None]:
        """Raw `mujoco.rollout` of the same models for the same physics steps, from the env's
        current states, with no env layer and no layout work (the throughput bench's
        reference)."""
        controls = [self.shard_control(v).copy() for v in velocities]
        out = np.empty((len(self.models), self.substeps, self.shard_state.shape[1]))

        def run() -> None:
            state = self.shard_state.copy()
            for u in controls:
                self._rollout.rollout(self.models, self.datas, state, u, nstep=self.substeps,
                                      state=out, skip_checks=True)  # fmt: skip
                state = out[:, -1].copy()

        return run

    def bench_figures(self) -> dict:
        return {"threads": self.nthread, "shard_size": self.shard_size}

    def shard_control(self, velocity: np.ndarray) -> np.ndarray:
        """(num_envs, 6) velocities -> the shards' controls (shards, substeps, 6 x slots),
        held over the substeps; phantom slots keep zero."""
        self._ctrl0.reshape(-1)[: 6 * self.num_envs] = velocity.reshape(-1)
        self._ctrl[:] = self._ctrl0[:, None, :]
        return self._ctrl

    def contacts(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Contacts of env i's peg in its current state: distances (k,) m (negative:
        penetration) and normal forces (k,) N. For tests and diagnostics only."""
        self._scatter()
        m, d = self.models[self.shard_of[i]], self._scratch
        mujoco.mj_setState(m, d, self.shard_state[self.shard_of[i]], STATE_SPEC)
        mujoco.mj_forward(m, d)
        return geom_contacts(m, d, range(self.peg_geom[i], self.peg_geom[i] + self.peg_ngeom[i]))

    def close(self) -> None:
        self._rollout.close()
