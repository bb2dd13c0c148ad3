"""BatchSim's contract on a second engine: PhysX 5 on the CPU (SAPIEN 3), the referee.

Each module is read from its USD file (sim/engines/physx/usd_module.py): the convex collision
pieces, the peg's collision mesh and its mass properties. Every env lives in one PhysX scene, on
a grid `spacing` apart, and collides only with its own module (collision groups: the upper 16
bits of the fourth group word are the env's id, which PhysX's filter never pairs across). The
peg's velocity is tracked by a PhysX D6 drive between the world and the peg frame (its origin
is the bottom-face centre): stiffness 0 and damping kv, the gains of the MuJoCo actuators
(`velocity_gains`), solved implicitly inside PhysX's solver as MuJoCo's `discrete`
integrator does; no force limit, as in MuJoCo. The drive's targets are in the world axes,
which are every module frame's.

Friction and restitution follow PhysX's own model: each env's peg and pieces share one
material, whose static and dynamic friction and restitution are the task's draws (PhysX
averages the two materials of a contact, so the pair gets exactly the draw). MuJoCo has one
Coulomb coefficient (it takes the dynamic draw) and maps restitution onto a damping ratio.

State layout as BatchSim: (num_envs, 14) = [time, pos (3), quat w x y z (4), linear velocity
of the peg frame's origin (module frame, 3), angular velocity (peg frame, 3)].
"""

from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np

from assetgen.core.mujoco_config import velocity_gains
from assetgen.core.rotations import quat_to_matrix
from sim.assets.loading import AssetError, ModuleAsset, verify_module_files
from sim.engines.base import EngineOptions, EngineSim
from sim.engines.physx.config import PhysxConfig
from sim.engines.physx.usd_module import USD_FILE, UsdModule, load_usd_module
from sim.task import kernel as K
from sim.task.config import PhysicsConfig, TaskConfig


def _sapien():
    try:
        import sapien
    except ModuleNotFoundError as e:
        # the command line turns this into its one-line advice (cli.missing_extra_message)
        raise ModuleNotFoundError(
            f"the PhysX engine needs SAPIEN ({e}): pip install -e '.[physx]'", name=e.name
        ) from e
    return sapien


COOK_TOLERANCE = 0.02
"""The most PhysX's cooked hull may differ from the file's near the hole (within the
clearance + HOLE_REACH of the peg at its design pose) or anywhere on the peg, as a fraction
of the clearance. PhysX's cooking keeps at most about a hundred corners of a round shape and
drops corners that stand out by a few hundredths of a millimetre from a large piece; away
from the hole that changes no contact the task makes."""
HOLE_REACH = 0.003
"""m: how far from the peg's design pose a piece's surface counts as the hole's."""


def _cook(px, vertices: np.ndarray, material, scale: float):
    """A convex shape of `vertices` (m) cooked scaled up by `scale`, and per input point how
    far it lies outside the cooked hull (m; a cooked corner that is no input point counts
    for every point)."""
    shape = px.PhysxCollisionShapeConvexMesh(
        np.asarray(vertices, dtype=np.float32) * scale, [1.0 / scale] * 3, material
    )
    cooked = np.asarray(shape.vertices, dtype=float) / scale
    tri = cooked[np.asarray(shape.triangles, dtype=np.int64)]
    # the cooked hull is the input's hull when its corners are input points (none moved or
    # invented) and no input point lies outside it
    moved = np.linalg.norm(cooked[:, None] - vertices[None], axis=2).min(axis=1).max()
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal *= np.sign(np.einsum("ti,ti->t", normal, tri[:, 0] - cooked.mean(axis=0)))[:, None]
    outside = (
        np.einsum("ti,vi->vt", normal, vertices) - np.einsum("ti,ti->t", normal, tri[:, 0])
    ).max(axis=1)
    return shape, np.maximum(np.maximum(outside, moved), 0.0)


MAX_SPLITS = 4
"""How many times a shape PhysX cooks too coarsely is halved (up to 16 parts)."""


def _halves(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The convex hull of points v cut in two across its longest extent, at its middle:
    each half's points are v's on its side and the hull edges' crossings of the plane."""
    from scipy.spatial import ConvexHull

    axis = int(np.argmax(np.ptp(v, axis=0)))
    mid = 0.5 * (v[:, axis].min() + v[:, axis].max())
    edges = np.concatenate(
        [ConvexHull(v).simplices[:, [a, b]] for a, b in ((0, 1), (1, 2), (2, 0))]
    )
    a, b = v[edges[:, 0]], v[edges[:, 1]]
    da, db = a[:, axis] - mid, b[:, axis] - mid
    cross = (da * db) < 0
    t = (da[cross] / (da[cross] - db[cross]))[:, None]
    cut = a[cross] + t * (b[cross] - a[cross])
    cut[:, axis] = mid
    return (
        np.concatenate([v[v[:, axis] <= mid], cut]),
        np.concatenate([v[v[:, axis] >= mid], cut]),
    )


def _hull_mesh(px, vertices: np.ndarray, material, cfg: PhysxConfig):
    """The convex hull of `vertices` as a triangle mesh (static bodies only): PhysX keeps a
    triangle mesh's vertices as they are."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(vertices)
    tri = hull.simplices.copy()
    # outward winding: each triangle's normal away from the hull's inside
    p = vertices[tri]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = np.einsum("ti,ti->t", normal, p[:, 0] - vertices[hull.vertices].mean(axis=0)) < 0
    tri[flip] = tri[flip][:, ::-1]
    shape = px.PhysxCollisionShapeTriangleMesh(
        np.asarray(vertices, dtype=np.float32), tri.astype(np.uint32), [1.0] * 3, material
    )
    shape.set_contact_offset(cfg.contact_offset)
    shape.set_rest_offset(cfg.rest_offset)
    return shape


def _convex(
    px, vertices: np.ndarray, material, cfg: PhysxConfig, relevant, clearance: float,
    where: str, depth: int = 0, static: bool = False,
) -> tuple[list, float]:  # fmt: skip
    """Convex shapes whose union is the hull of `vertices`, and their cooking error (m)
    over the points for which relevant(points) is True.

    PhysX's cooking is not monotonic in the scale (float32 hulls): the scales cook_scale,
    x10, x3 and x30 are tried in turn, and the first whose error is within COOK_TOLERANCE of
    the clearance is taken. Its tolerance also grows with the shape's size, so a shape no
    scale cooks well enough is halved, MAX_SPLITS times at most. Past that, a static part
    becomes a triangle mesh of its hull (exact), and a dynamic one an AssetError."""
    best = None
    mask = relevant(vertices)
    for f in (1.0, 10.0, 3.0, 30.0):
        shape, out = _cook(px, vertices, material, cfg.cook_scale * f)
        error = float(out[mask].max()) if mask.any() else 0.0
        if best is None or error < best[1]:
            best = (shape, error)
        if error <= COOK_TOLERANCE * clearance:
            break
    shape, error = best
    if error > COOK_TOLERANCE * clearance:
        if depth >= MAX_SPLITS and static:
            return [_hull_mesh(px, vertices, material, cfg)], 0.0
        if depth >= MAX_SPLITS:
            raise AssetError(
                f"{where}: PhysX's convex cooking changes the hull by {error * 1e3:.4f} mm "
                f"near the hole, over {COOK_TOLERANCE:.0%} of the clearance, even in "
                f"{2**MAX_SPLITS} parts; this peg cannot be simulated in PhysX"
            )
        shapes, error = [], 0.0
        for half in _halves(vertices):
            got, err = _convex(
                px, half, material, cfg, relevant, clearance, where, depth + 1, static
            )
            shapes += got
            error = max(error, err)
        return shapes, error
    shape.set_contact_offset(cfg.contact_offset)
    shape.set_rest_offset(cfg.rest_offset)
    return [shape], error


def _planes(points: np.ndarray) -> np.ndarray:
    """(F, 4) outward unit planes [n, -d] of the convex hull of points (n . x - d <= 0)."""
    from scipy.spatial import ConvexHull

    return ConvexHull(points).equations


class PhysxBatchSim(EngineSim):
    """`num_envs` peg-in-hole scenes in one PhysX scene, behind the engine interface
    (sim/engines/base.py), for evaluation: no module rotation, no saved env state."""

    def __init__(
        self,
        env_assets: list[ModuleAsset],
        task: TaskConfig,
        physx: PhysxConfig | None = None,
    ) -> None:
        sapien = _sapien()
        px = sapien.physx
        self.task = task
        self._controller = task.physics or PhysicsConfig()
        """Where the drive's gains (tracking time constant, limits) and the runaway speed
        come from: the task's MuJoCo physics, or the project's default."""
        self.physx = cfg = (physx or PhysxConfig()).validate(task.control_dt)
        self.num_envs = n = len(env_assets)
        if n >= 1 << 16:
            raise ValueError(f"num_envs = {n}: one PhysX scene holds at most 65535 envs")
        self.substeps = cfg.substeps(task.control_dt)
        # PhysX copies these defaults into the scene, bodies and shapes made after them
        px.set_scene_config(
            gravity=[0.0, 0.0, 0.0],
            bounce_threshold=cfg.bounce_threshold,
            enable_pcm=cfg.pcm,
            enable_tgs=True,
            enable_ccd=False,
            enable_enhanced_determinism=True,
            enable_friction_every_iteration=True,
            cpu_workers=cfg.cpu_workers,
        )
        px.set_body_config(
            solver_position_iterations=cfg.position_iterations,
            solver_velocity_iterations=cfg.velocity_iterations,
            sleep_threshold=0.0,
        )
        px.set_shape_config(contact_offset=cfg.contact_offset, rest_offset=cfg.rest_offset)
        self._system = px.PhysxCpuSystem()
        self._system.timestep = cfg.timestep
        self.scene = sapien.Scene([self._system])

        side = math.ceil(math.sqrt(n))
        grid = np.stack(np.divmod(np.arange(n), side), axis=1).astype(float)
        self.origin = np.zeros((n, 3))
        """(num_envs, 3) each module frame's origin in the scene."""
        self.origin[:, :2] = (grid - (side - 1) / 2) * cfg.spacing

        self.cook_error = np.zeros(n)
        """Per env: the most PhysX's cooked hulls differ from the file's pieces (near the
        hole) and peg, m."""
        self.split_pieces = np.zeros(n, dtype=int)
        """Per env: how many of its pieces (the peg included) PhysX takes in parts."""
        self.mesh_parts = np.zeros(n, dtype=int)
        """Per env: how many parts of its pieces are triangle meshes (see _convex)."""
        self._env_of: dict[int, int] = {}
        self.materials = []
        self.bodies = []
        self._entities = []
        self._drives = []
        self.usd: list[UsdModule] = []
        # the USD it reads, checked against the dataset's manifest (once per process)
        folders = {a.folder for a in env_assets if a.folder is not None}
        verify_module_files(sorted(folders), (USD_FILE,))
        for e, asset in enumerate(env_assets):
            if asset.folder is None:
                raise ValueError(
                    f"module {asset.id}: the PhysX engine reads each module's USD file; give "
                    "modules loaded from a dataset folder"
                )
            if asset.peg_pieces:
                raise AssetError(
                    f"{asset.folder}: the PhysX engine takes Table I modules (a convex peg); "
                    "this peg is made of pieces"
                )
            usd = load_usd_module(asset.folder, asset)
            self.usd.append(usd)
            self._add_env(sapien, px, e, usd, asset)
        self._com_local = np.array([u.peg_com for u in self.usd])
        self.state = np.zeros((n, 14))
        self.state[:, 4] = 1.0
        for e in range(n):
            self.set_state(e, self.state[e, 1:8], np.zeros(6))
        self._time = 0.0

    def _add_env(self, sapien, px, e: int, usd: UsdModule, asset: ModuleAsset) -> None:
        cfg = self.physx
        material = px.PhysxMaterial(usd.static_friction, usd.dynamic_friction, usd.restitution)
        groups = [1, 1, 0, (e + 1) << 16]
        static = px.PhysxRigidStaticComponent()
        design = usd.peg_design_pose
        hole = _planes(usd.peg_vertices @ design[:3, :3].T + design[:3, 3])
        reach = asset.clearance + HOLE_REACH

        def near(points: np.ndarray) -> np.ndarray:
            # only the points near the peg's design pose shape the hole
            return (points @ hole[:, :3].T + hole[:, 3]).max(axis=1) < reach

        for j, v in enumerate(usd.pieces):
            where = f"{usd.path}: prim /module/collision_pieces/piece_{j:03d}"
            shapes, error = _convex(px, v, material, cfg, near, asset.clearance, where, static=True)
            self.cook_error[e] = max(self.cook_error[e], error)
            self.split_pieces[e] += len(shapes) > 1
            self.mesh_parts[e] += sum(
                isinstance(x, px.PhysxCollisionShapeTriangleMesh) for x in shapes
            )
            for shape in shapes:
                shape.set_collision_groups(groups)
                static.attach(shape)
        module = sapien.Entity()
        module.name = f"module_{e}"
        module.add_component(static)
        module.pose = sapien.Pose(self.origin[e])
        self.scene.add_entity(module)

        body = px.PhysxRigidDynamicComponent()
        where = f"{usd.path}: prim /module/peg/mesh"

        def every(points: np.ndarray) -> np.ndarray:
            return np.ones(len(points), dtype=bool)

        shapes, error = _convex(px, usd.peg_vertices, material, cfg, every, asset.clearance, where)
        self.cook_error[e] = max(self.cook_error[e], error)
        self.split_pieces[e] += len(shapes) > 1
        for shape in shapes:
            shape.set_collision_groups(groups)
            body.attach(shape)
        body.set_mass(usd.peg_mass)
        body.set_inertia(usd.peg_inertia_diag.astype(np.float32))
        body.set_cmass_local_pose(sapien.Pose(usd.peg_com, usd.peg_principal_axes))
        body.disable_gravity = True
        body.linear_damping = 0.0
        body.angular_damping = 0.0
        body.max_angular_velocity = 1e4
        body.max_depenetration_velocity = cfg.max_depenetration_velocity
        peg = sapien.Entity()
        peg.name = f"peg_{e}"
        peg.add_component(body)
        # the drive's parent is the world: its frame sits at the module's origin, so the
        # targets are velocities in the module frame
        drive = px.PhysxDriveComponent(body)
        drive.set_pose_in_parent(sapien.Pose(self.origin[e]))
        kv_lin, kv_rot = velocity_gains(
            asset.peg_mass, asset.peg_com, asset.peg_inertia, self._controller,
            self.task.max_lin_vel, self.task.max_ang_vel,
        )  # fmt: skip
        drive.set_drive_property_x(0.0, kv_lin)
        drive.set_drive_property_y(0.0, kv_lin)
        drive.set_drive_property_z(0.0, kv_lin)
        drive.set_drive_property_slerp(0.0, kv_rot)
        peg.add_component(drive)
        self.scene.add_entity(peg)
        self.kv = (kv_lin, kv_rot)
        """The drive's linear and angular damping (the last env's: the stress benchmark
        runs one module at a time)."""
        self._env_of[id(body)] = e
        self.materials.append(material)
        self.bodies.append(body)
        self._entities.append(peg)
        self._drives.append(drive)

    # ------------------------------------------------------------------ state access

    def set_pose(self, idx: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
        """Place pegs `idx` at rest: pos (k, 3), quat (k, 4) in their module frames."""
        quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
        for j, e in enumerate(np.atleast_1d(idx).tolist()):
            self.state[e, 1:4] = pos[j]
            self.state[e, 4:8] = quat[j]
            self.state[e, 8:14] = 0.0
            self.set_state(e, self.state[e, 1:8], np.zeros(6))

    def set_material(
        self, idx: np.ndarray, static: np.ndarray, dynamic: np.ndarray, restitution: np.ndarray
    ) -> None:
        """Envs `idx`' contact material: PhysX's static and dynamic friction and restitution
        (k,) each, shared by the peg and its module."""
        for j, e in enumerate(np.atleast_1d(idx).tolist()):
            m = self.materials[e]
            m.static_friction = float(static[j])
            m.dynamic_friction = float(dynamic[j])
            m.restitution = float(restitution[j])

    # ------------------------------------------------------------------ stepping

    rotates_modules = False

    @classmethod
    def create(cls, env_assets, task, spare_assets, options: EngineOptions) -> PhysxBatchSim:
        return cls(env_assets, task, options.physx)

    def protocol(self) -> dict:
        """PhysX's step and settings: its timestep is the evaluation's."""
        return {"timestep": self.physx.timestep, "physx": asdict(self.physx)}

    def bench_figures(self) -> dict:
        return {"timestep": self.physx.timestep}

    def step(self, velocity: np.ndarray, live: np.ndarray | None = None) -> np.ndarray:
        """One control step at the commanded velocities (num_envs, 6): linear (m/s) and
        angular (rad/s) of the peg's bottom-face centre in the module frame. Returns the
        unstable flags (non-finite state, or a peg faster than the runaway speed)."""
        self.set_velocity_targets(velocity)
        for _ in range(self.substeps):
            self.scene.step()
        self._time += self.task.control_dt
        self._read()
        unstable = np.empty(self.num_envs, dtype=bool)
        K.check_unstable(self.state, K.Checks.of(self._controller), unstable)
        return unstable

    # ------------------------------------------------------------------ one physics step
    # (the contact stress benchmark drives the pegs step by step)

    def set_velocity_targets(self, velocity: np.ndarray) -> None:
        """The drives' targets (num_envs, 6), held until changed."""
        v = np.asarray(velocity, dtype=np.float32)
        for e, drive in enumerate(self._drives):
            drive.set_drive_velocity_target(v[e, :3], v[e, 3:])

    def physics_step(self) -> None:
        """One PhysX step; read the state with `read_state`."""
        self.scene.step()
        self._time += self.physx.timestep

    def set_state(self, e: int, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Env e's peg at qpos (position, quaternion w x y z) with qvel (the peg frame
        origin's linear velocity in the module frame, angular velocity in the peg frame)."""
        import sapien

        q = qpos[3:] / np.linalg.norm(qpos[3:])
        self._entities[e].pose = sapien.Pose(self.origin[e] + qpos[:3], q)
        rot = _matrix(q)
        w = rot @ qvel[3:]
        com = rot @ np.asarray(self.bodies[e].cmass_local_pose.p, dtype=float)
        self.bodies[e].set_angular_velocity(w)
        self.bodies[e].set_linear_velocity(qvel[:3] + np.cross(w, com))

    def set_drive(self, e: int, on: bool) -> None:
        """Env e's velocity drive on (the task's gains) or off (a free peg)."""
        kv_lin, kv_rot = self.kv if on else (0.0, 0.0)
        d = self._drives[e]
        d.set_drive_property_x(0.0, kv_lin)
        d.set_drive_property_y(0.0, kv_lin)
        d.set_drive_property_z(0.0, kv_lin)
        d.set_drive_property_slerp(0.0, kv_rot)

    def penetration(self) -> np.ndarray:
        """(num_envs,) each peg's deepest penetration after the last step, m (0: none)."""
        # hundreds of pairs a step lie within the contact offset: the loop is kept lean (it
        # was 1.5 times PhysX's own step in the stress benchmark)
        pen = [0.0] * self.num_envs
        env_of = self._env_of
        for c in self.scene.get_contacts():
            b0, b1 = c.bodies
            e = env_of.get(id(b0))
            if e is None:
                e = env_of.get(id(b1))
                if e is None:
                    continue
            deepest = -min((p.separation for p in c.points), default=0.0)
            if deepest > pen[e]:
                pen[e] = deepest
        return np.array(pen)

    def read_state(self) -> np.ndarray:
        """The state after the last step (see the module docstring), read from PhysX."""
        self._read()
        return self.state

    def _read(self) -> None:
        # one packed copy of every body's pose and velocity (13 float32 each, in the order
        # the bodies were added: quaternion w x y z, actor position, the centre of mass's
        # linear velocity and the angular velocity, world frame) instead of five property
        # reads per env
        a = np.frombuffer(self._system.pack(), dtype=np.float32).reshape(self.num_envs, 13)
        a = a.astype(float)
        q, p, v_com, w = a[:, :4], a[:, 4:7], a[:, 7:10], a[:, 10:13]
        rot = quat_to_matrix(q)
        com = np.einsum("nij,nj->ni", rot, self._com_local)  # the COM from the peg frame
        s = self.state
        s[:, 0] = self._time
        s[:, 1:4] = p - self.origin
        s[:, 4:8] = q
        s[:, 8:11] = v_com - np.cross(w, com)
        s[:, 11:14] = np.einsum("nji,nj->ni", rot, w)

    def _read_each(self) -> np.ndarray:
        """The state read body by body through SAPIEN's properties (tests hold `_read`,
        which reads the packed copy, to it)."""
        s = self.state.copy()
        for e, (peg, body) in enumerate(zip(self._entities, self.bodies, strict=True)):
            pose = peg.pose
            p, q = np.asarray(pose.p, dtype=float), np.asarray(pose.q, dtype=float)
            w = np.asarray(body.angular_velocity, dtype=float)
            v_com = np.asarray(body.linear_velocity, dtype=float)
            com = np.asarray((pose * body.cmass_local_pose).p, dtype=float)
            s[e, 1:4] = p - self.origin[e]
            s[e, 4:8] = q
            s[e, 8:11] = v_com + np.cross(w, p - com)
            s[e, 11:14] = _rotate_inv(q, w)
        return s

    def gather(self) -> None:
        """The state is read after every step (BatchSim's contract)."""

    def contacts(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Contacts of env i's peg after the last step: separations (k,) m (negative:
        penetration) and normal forces (k,) N."""
        dist, force = [], []
        dt = self.physx.timestep
        for c in self.scene.get_contacts():
            if self.bodies[i] not in c.bodies:
                continue
            for p in c.points:
                dist.append(float(p.separation))
                force.append(float(np.linalg.norm(p.impulse)) / dt)
        return np.array(dist), np.array(force)

    def close(self) -> None:
        self._entities.clear()
        self._drives.clear()


def _rotate_inv(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v (world) in the frame of the unit quaternion q = (w, x, y, z)."""
    return _matrix(q).T @ v


def _matrix(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of the unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
