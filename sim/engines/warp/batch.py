"""BatchSim's contract on the GPU: every env a world of one MuJoCo Warp model.

MuJoCo Warp (the `warp` extra) steps many worlds of one model at once, and lets each world
have its own values of the model's batched fields, mesh ids among them (`geom_dataid`). So one
model holds every module's meshes, and its geoms are *slots*: as many static piece slots as
the module with the most pieces has pieces, and the peg's geom. A world takes its module's
meshes into its slots; the slots its module does not use hold a tiny mesh parked 10 m below
the module, out of every peg's reach.

Every value a module changes is taken from that module's own model, compiled by the CPU
simulator's `sim.engines.mujoco.scene.build_spec` with its pieces padded to the slot count:
the batched fields whose values differ between modules (geom frames and bounds, the peg's mass and
inertia, the actuator gains, ...) are copied per world, so a world is its module's CPU model
in everything but float precision. MuJoCo Warp computes the poses of geoms fixed to the world
once, so the slots' poses are written per world here as well.

The physics is the task's `PhysicsConfig`, as on the CPU, in float32 (MuJoCo Warp's
precision). MuJoCo Warp resets a world whose state turns non-finite (its autoreset, which it
needs on); such a world's clock restarts, which `step` reports as unstable, as the CPU
simulator reports a stalled shard.

What stays on the host in this version: the env state (num_envs, 14) and the task's
arithmetic (sim/env.py). Each control step uploads the commands and the state and reads the
state back, one copy each way; the substeps in between run on the device with no host
involvement (a captured CUDA graph on a GPU).
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from collections.abc import Callable

import mujoco
import numpy as np

from sim.assets.loading import AssetError, ModuleAsset
from sim.engines.base import EngineOptions, EngineSim
from sim.engines.mujoco.scene import build_spec, contact_solref, restitution_to_dampratio
from sim.task import kernel as K
from sim.task.config import TaskConfig

PARK_DEPTH = 10.0
"""m below the module origin where unused piece slots lie."""
_PARK = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float) * 1e-3
_PARK_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


NCONMAX = 64
"""Contacts allocated per world, on average: MuJoCo Warp's contact arrays are shared by all
worlds, so one world may hold more while the total fits. With multiccd on every mesh, up to
92 contacts were seen in one world in the contact stress benchmark's runs of two test
modules (pushes into corners, twisting); the engine raises when a step fills the total."""
NJMAX = 384
"""Constraint rows allocated per world, each world's own: 3 a contact with the elliptic cone;
up to 276 seen in those runs."""


def load_warp():
    try:
        import warp as wp

        # Warp reports its start and every kernel module it loads on stdout, which `--json`
        # output is; quiet before mujoco_warp's import starts it
        wp.config.quiet = True
        import mujoco_warp as mjw
    except ModuleNotFoundError as e:
        # the command line turns this into its one-line advice (cli.missing_extra_message)
        raise ModuleNotFoundError(
            f"the mujoco-warp engine needs MuJoCo Warp ({e}): pip install -e '.[warp]'",
            name=e.name,
        ) from e
    return wp, mjw


@functools.cache
def _contact_kernel():
    """A Warp kernel: world idx[i]'s peg geom gets friction[i] and solref[i]."""
    wp, _ = load_warp()

    @wp.kernel
    def set_peg_contact(
        idx: wp.array(dtype=wp.int32),
        friction: wp.array(dtype=wp.vec3),
        solref: wp.array(dtype=wp.vec2),
        geom: int,
        geom_friction: wp.array2d(dtype=wp.vec3),
        geom_solref: wp.array2d(dtype=wp.vec2),
    ):
        i = wp.tid()
        geom_friction[idx[i], geom] = friction[i]
        geom_solref[idx[i], geom] = solref[i]

    return set_peg_contact


def default_device() -> str:
    """cuda:0 where Warp sees a GPU, else cpu."""
    wp, _ = load_warp()
    return "cuda:0" if wp.get_cuda_device_count() > 0 else "cpu"


CPU_SLOWDOWN = 270
"""How many times slower an env step is on Warp's CPU device than on the CPU simulator, one
thread each: 14 against 3,866 env steps/s at 16 envs on the 2-core machine (`bench_warp`
and `bench_sim`, 20 control steps, 2026-11-27)."""


def require_gpu(allow_cpu: bool = False) -> None:
    """ValueError when Warp sees no GPU and the user has not allowed its CPU device: the
    commands would otherwise run on the CPU, orders of magnitude slower, without a word."""
    if allow_cpu or default_device() != "cpu":
        return
    raise ValueError(
        "--sim mujoco-warp: Warp sees no CUDA GPU on this machine and would run on the CPU, "
        f"about {CPU_SLOWDOWN} times slower than --sim mujoco; use --sim mujoco, or pass "
        "--allow-cpu to run it anyway"
    )


def slot_spec(asset: ModuleAsset, task: TaskConfig, slots: int) -> mujoco.MjSpec:
    """The CPU simulator's spec of one module (`sim.engines.mujoco.scene.build_spec`), its
    pieces padded to `slots` geoms with parked tiny meshes. The parked geoms follow the pieces
    on the world body, so piece slot i is geom i and the peg's geom is geom `slots` in every
    module."""
    spec = build_spec(
        [asset], task.physics, max_lin_vel=task.max_lin_vel, max_ang_vel=task.max_ang_vel
    )
    mesh = spec.add_mesh()
    mesh.name = "park"
    mesh.uservert = _PARK.ravel().tolist()
    mesh.userface = _PARK_FACES.ravel().tolist()
    for i in range(len(asset.pieces), slots):
        g = spec.worldbody.add_geom()
        g.name = f"slot{i}"
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = "park"
        g.pos = [0.0, 0.0, -PARK_DEPTH]
        # collidable as a piece: a slot's collision bits are every world's (MuJoCo Warp
        # shares them), and another module may hold a piece in it
        g.contype = 0
        g.conaffinity = 1
    return spec


class WarpBatchSim(EngineSim):
    """`num_envs` peg-in-hole scenes, one MuJoCo Warp world each, behind the engine interface
    (sim/engines/base.py): module rotation included, no saved env state. State layout as
    BatchSim's: [time, pos (3), quat w x y z (4), qvel (6)].

    env_assets: each env's module; spare_assets: further modules an env may be put on with
    `set_module`. device: a Warp device ("cuda:0", "cpu"); None: the GPU if there is one.
    nconmax, njmax: contacts and constraint rows allocated per world. per_world: further
    batched model fields every world gets its own copy of, to change them world by world
    (the peg's contact fields always are).
    """

    def __init__(
        self,
        env_assets: list[ModuleAsset],
        task: TaskConfig,
        spare_assets: list[ModuleAsset] | None = None,
        device: str | None = None,
        nconmax: int = NCONMAX,
        njmax: int = NJMAX,
        per_world: tuple[str, ...] = (),
    ) -> None:
        wp, mjw = load_warp()
        if task.physics is None:
            raise ValueError("WarpBatchSim needs the task's physics (TaskConfig.physics)")
        self.task = task
        self.substeps = task.physics.substeps
        self.num_envs = n = len(env_assets)
        self.device = device or default_device()
        self.wp, self._mjw = wp, mjw
        pool: dict[str, ModuleAsset] = {}
        for a in list(env_assets) + list(spare_assets or ()):
            if a.peg_pieces:
                raise AssetError(
                    f"module {a.id}: the mujoco-warp engine takes Table I modules (a convex "
                    "peg); this peg is made of pieces"
                )
            pool.setdefault(a.id, a)
        self.slots = max(len(a.pieces) for a in pool.values())
        self.peg_geom = self.slots
        """The peg's geom id in every world."""

        # each module's own model, slots padded: the source of every per-world value
        own = {mid: slot_spec(a, task, self.slots).compile() for mid, a in pool.items()}
        # one model holding every module's meshes (`m<k>_<name>`), with the first module's
        # geoms as the slots
        combined = slot_spec(next(iter(pool.values())), task, self.slots)
        for k, a in enumerate(pool.values()):
            m = own[a.id]
            for j in range(m.nmesh):
                name = m.mesh(j).name
                if name == "park":
                    continue
                shape = a.peg if name == "peg" else a.pieces[int(name.removeprefix("piece"))]
                mesh = combined.add_mesh()
                mesh.name = f"m{k}_{name}"
                mesh.uservert = np.asarray(shape.vertices, float).ravel().tolist()
                mesh.userface = np.asarray(shape.faces, int).ravel().tolist()
                # MuJoCo builds a mesh's hull graph and face polygons only where a geom
                # collides with it, or where its inertia comes from the hull. No geom names
                # these meshes (worlds take them by mesh id), and without polygons MuJoCo
                # Warp's multiccd finds one contact where MuJoCo finds four: a peg pressed
                # flat onto the hole's floor sank 0.23 mm (tests/test_contact_stress_warp.py)
                mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_CONVEX
        self.mjm = combined.compile()
        # MuJoCo Warp needs its autoreset on (the CPU simulator turns it off, see module doc)
        self.mjm.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        mesh_id = {self.mjm.mesh(j).name: j for j in range(self.mjm.nmesh)}
        self._dataid: dict[str, np.ndarray] = {}
        for k, (mid, m) in enumerate(own.items()):
            names = [m.mesh(int(d)).name for d in m.geom_dataid]
            self._dataid[mid] = np.array(
                [mesh_id["park" if s == "park" else f"m{k}_{s}"] for s in names], dtype=np.int32
            )

        # the batched fields whose values differ between modules, per module
        batched = [
            f.name
            for f in dataclasses.fields(mjw.Model)
            if getattr(f.type, "shape", ())[:1] == ("*",) and hasattr(self.mjm, f.name)
        ]
        first = next(iter(own.values()))
        self._fields = ["geom_dataid"] + [
            name
            for name in batched
            if name != "geom_dataid"
            and np.shape(getattr(first, name)) == np.shape(getattr(self.mjm, name))
            and any(
                not np.array_equal(getattr(first, name), getattr(m, name)) for m in own.values()
            )
        ]
        always = ("geom_friction", "geom_solref", *per_world)
        self._fields += [f for f in always if f not in self._fields]
        self.per_module = {
            mid: {
                f: (self._dataid[mid] if f == "geom_dataid" else np.array(getattr(m, f)))
                for f in self._fields
            }
            for mid, m in own.items()
        }
        # static slot poses (the world body is at the origin)
        self._slot_pose = {}
        for mid, m in own.items():
            d = mujoco.MjData(m)
            mujoco.mj_kinematics(m, d)
            self._slot_pose[mid] = (
                d.geom_xpos[: self.slots].copy(),
                d.geom_xmat[: self.slots].copy(),
            )

        with wp.ScopedDevice(self.device), warnings.catch_warnings():
            # the pieces' friction is 0 on purpose: the peg's geom has priority, its
            # (randomised) friction is the contact's, as on the CPU
            warnings.filterwarnings("ignore", message=".*MJ_MINMU.*")
            self.model = mjw.put_model(self.mjm, batch_sizes={f: n for f in self._fields})
            self.data = mjw.make_data(self.mjm, nworld=n, nconmax=nconmax, njmax=njmax)
        self.host = {
            f: np.stack([self.per_module[a.id][f] for a in env_assets]) for f in self._fields
        }
        """Per-world values of the batched fields (host copies, uploaded when changed)."""
        self.env_module = [a.id for a in env_assets]
        """Each world's module id."""
        self._upload_all = True
        """Every world's fields go up at the next step (at the start)."""
        self._moved: set[int] = set()
        """Worlds put on another module since the last step: their rows go up."""
        self._contact: set[int] = set()
        """Worlds whose peg contact was drawn since the last step: one scatter kernel."""
        self.state = np.zeros((n, 14))
        self.state[:, 4] = 1.0
        self.state[:, 3] = 0.2
        self._ctrl = np.zeros((n, 6), dtype=np.float32)
        self._checks = K.Checks.of(task.physics)
        self._graph = None

    # ------------------------------------------------------------------ contact and modules

    def set_contact(self, idx: np.ndarray, friction: np.ndarray, dampratio: np.ndarray) -> None:
        """Peg-module contact of envs `idx`: Coulomb friction (k,) and damping ratio (k,)
        (the peg geom's priority makes its values the contact's, as on the CPU)."""
        idx = np.atleast_1d(idx)
        self.host["geom_friction"][idx, self.peg_geom, 0] = friction
        self.host["geom_solref"][idx, self.peg_geom] = contact_solref(dampratio, self.task.physics)
        self._contact.update(idx.tolist())

    def set_material(
        self, idx: np.ndarray, static: np.ndarray, dynamic: np.ndarray, restitution: np.ndarray
    ) -> None:
        """The task's contact draws, as the CPU simulator takes them (BatchSim.set_material)."""
        del static
        self.set_contact(idx, dynamic, restitution_to_dampratio(restitution, self.task.physics))

    def set_module(self, e: int, module_id: str) -> None:
        """Put env `e` on module `module_id` (one given at construction). Place the peg with
        `set_pose` and set its contact with `set_contact` next."""
        if module_id not in self.per_module:
            raise ValueError(f"module {module_id!r} was not given to this WarpBatchSim")
        for f, v in self.per_module[module_id].items():
            self.host[f][e] = v
        self.env_module[e] = module_id
        self._moved.add(int(e))

    def gather(self) -> None:
        """The state is read after every step (BatchSim's contract)."""

    # ------------------------------------------------------------------ stepping

    def _upload_model(self) -> None:
        """Send what changed since the last step: every world's fields at the start, the
        rows of worlds that changed module, the pegs' new contact draws (one kernel)."""
        wp = self.wp
        if self._upload_all:
            worlds = list(range(self.num_envs))
            for f, v in self.host.items():
                arr = getattr(self.model, f)
                arr.assign(wp.array(self.cast(f, v), dtype=arr.dtype, device=self.device))
            rows = [self.pose_rows(mid) for mid in self.env_module]
            self.data.geom_xpos.assign(np.stack([r[0] for r in rows]))
            self.data.geom_xmat.assign(np.stack([r[1] for r in rows]))
            self._upload_all = False
        else:
            worlds = sorted(self._moved)
            for e in worlds:
                for f, v in self.host.items():
                    arr = getattr(self.model, f)[e]
                    arr.assign(wp.array(self.cast(f, v[e]), dtype=arr.dtype, device=self.device))
                xpos, xmat = self.pose_rows(self.env_module[e])
                self.data.geom_xpos[e].assign(wp.array(xpos, dtype=wp.vec3, device=self.device))
                self.data.geom_xmat[e].assign(wp.array(xmat, dtype=wp.mat33, device=self.device))
        contact = sorted(self._contact.difference(worlds))
        if contact:
            g = self.peg_geom
            idx = np.array(contact, dtype=np.int32)
            fr = self.host["geom_friction"][idx, g].astype(np.float32)
            sr = self.host["geom_solref"][idx, g].astype(np.float32)
            wp.launch(
                _contact_kernel(),
                dim=len(idx),
                inputs=[
                    wp.array(idx, dtype=wp.int32, device=self.device),
                    wp.array(fr, dtype=wp.vec3, device=self.device),
                    wp.array(sr, dtype=wp.vec2, device=self.device),
                    g,
                ],
                outputs=[self.model.geom_friction, self.model.geom_solref],
                device=self.device,
            )
        self._moved.clear()
        self._contact.clear()

    def pose_rows(self, module_id: str) -> tuple[np.ndarray, np.ndarray]:
        """A world's geom poses (ngeom, 3) and (ngeom, 3, 3) on `module_id`: its fixed slots'
        poses, the peg's left at the origin (the step recomputes it)."""
        xpos = np.zeros((self.mjm.ngeom, 3), np.float32)
        xmat = np.tile(np.eye(3, dtype=np.float32), (self.mjm.ngeom, 1, 1))
        pos, mat = self._slot_pose[module_id]
        xpos[: self.slots] = pos
        xmat[: self.slots] = mat.reshape(self.slots, 3, 3)
        return xpos, xmat

    @staticmethod
    def cast(field: str, v: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(v, dtype=np.int32 if field == "geom_dataid" else np.float32)

    def _substeps(self) -> None:
        for _ in range(self.task.physics.substeps):
            self._mjw.step(self.model, self.data)

    def _upload_state(self) -> None:
        self.data.ctrl.assign(self._ctrl)
        self.data.qpos.assign(self.state[:, 1:8].astype(np.float32))
        self.data.qvel.assign(self.state[:, 8:14].astype(np.float32))
        self.data.time.zero_()  # float32 time: each control step counts from 0

    def device_substeps(self, restore: Callable[[], None] | None = None) -> None:
        """One control step's substeps on the device, from and to the device's state (a
        captured CUDA graph on a GPU: one launch; the first call compiles and captures).
        restore: puts back the state the first call's compiling pass stepped (default: the
        host's state, uploaded)."""
        wp = self.wp
        with wp.ScopedDevice(self.device):
            if not self.device.startswith("cuda"):
                self._substeps()
                return
            if self._graph is None:
                self._substeps()  # compiles every kernel; capture needs them loaded
                (restore or self._upload_state)()
                with wp.ScopedCapture() as capture:
                    self._substeps()
                self._graph = capture.graph
            wp.capture_launch(self._graph)

    def device_memory_mb(self) -> float:
        """MB of the device's memory in use (the whole device's, on a GPU; NaN on the CPU)."""
        dev = self.wp.get_device(self.device)
        if not dev.is_cuda:
            return float("nan")
        return (dev.total_memory - dev.free_memory) / 2**20

    @classmethod
    def create(cls, env_assets, task, spare_assets, options: EngineOptions) -> WarpBatchSim:
        return cls(env_assets, task, spare_assets, device=options.device)

    def device_model_bytes(self) -> int:
        return int(self.mjm.nbuffer)

    def bench_figures(self) -> dict:
        return {"device": self.device, "timestep": self.task.physics.timestep,
                "device_memory_mb": self.device_memory_mb()}  # fmt: skip

    def step(self, velocity: np.ndarray, live: np.ndarray | None = None) -> np.ndarray:
        """One control step at the commanded velocities (num_envs, 6), as BatchSim.step.
        Returns the unstable flags: a non-finite state, a world MuJoCo Warp reset (its clock
        restarted), or a runaway peg."""
        if self._upload_all or self._moved or self._contact:
            self._upload_model()
        self._ctrl[:] = velocity
        self._upload_state()
        self.device_substeps()
        t = self.data.time.numpy().astype(float)
        self.state[:, 1:8] = self.data.qpos.numpy()
        self.state[:, 8:14] = self.data.qvel.numpy()
        self.state[:, 0] += self._checks.control_step
        self._check_capacity()
        unstable = np.empty(self.num_envs, dtype=bool)
        K.check_unstable(self.state, self._checks, unstable)
        unstable |= np.abs(t - self._checks.control_step) > 0.5 * self._checks.timestep
        return unstable

    def _check_capacity(self) -> None:
        """MuJoCo Warp drops collision pairs, contacts and constraint rows beyond those
        allocated (and prints a warning from its kernels): refuse to go on with fewer than
        the physics asks for. Its counters hold the control step's last substep."""
        d = self.data
        pairs, nacon = int(d.ncollision.numpy()[0]), int(d.nacon.numpy()[0])
        nefc = int(d.nefc.numpy().max())
        if max(pairs, nacon) >= d.naconmax or nefc >= d.njmax:
            raise RuntimeError(
                f"MuJoCo Warp ran out of room: {pairs} collision pairs and {nacon} contacts "
                f"of {d.naconmax} allocated ({d.naconmax // self.num_envs} a world), {nefc} "
                f"constraint rows of {d.njmax} a world; build WarpBatchSim with a larger "
                "nconmax / njmax"
            )

    def close(self) -> None:
        self._graph = None
