"""A robot holding the shown peg (`assetgen view --robot panda`), as plain numpy data: its
links' visual meshes in their body frames, and the links' poses for a peg pose.

The links are posed by the placement the simulator uses for spawns
(sim/robots/panda/kinematics.carry): from the joints of the last pose shown, so a slider, an
episode or a live policy moves the arm continuously. A live policy on the arm hands in the
simulator's own joints instead (`pose(..., joints=...)`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from preview.scene import PreviewError


@dataclass(frozen=True)
class LinkMesh:
    """One visual mesh of a link, in its body's frame (metres)."""

    body: str
    vertices: np.ndarray
    faces: np.ndarray
    rgb: tuple[int, int, int]


class ArmView:
    """A registered robot holding one module's peg (see the module doc)."""

    def __init__(self, module_dir, robot: str = "panda") -> None:
        import mujoco

        from assetgen.core.mujoco_config import physics_for
        from sim.assets.loading import load_module
        from sim.robots.registry import get_robot

        holder = get_robot(robot)
        asset = load_module(module_dir)
        why = holder.load("refuses")(asset)
        if why is not None:
            raise PreviewError(f"--robot {robot}: {why}")
        try:
            spec = holder.load("scene")(asset, physics_for(asset.clearance))
        except ValueError as e:
            raise PreviewError(f"--robot {robot}: {e}") from e
        self.label = holder.label
        self.model = m = spec.compile()
        self.data = mujoco.MjData(m)
        self._sim = holder.load("sim")
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, asset.bottom[:3, :3].ravel())
        above = asset.entrance[:3, 3] + asset.bottom[:3, 2] * self._sim.ALIGNED_HEIGHT
        from sim.robots.panda.kinematics import reach

        q, limits = reach(m, self.data, above, quat, np.random.default_rng(0))
        if q is None:
            raise PreviewError(
                f"--robot {robot}: module {asset.id}: the arm cannot hold its peg over the "
                f"hole; stopped by {', '.join(limits)}"
            )
        self.joints = q
        """The joints of the last pose shown."""
        self.links = self._link_meshes()
        self.bodies = sorted({link.body for link in self.links})

    def _link_meshes(self) -> list[LinkMesh]:
        import mujoco

        m = self.model
        out = []
        for g in range(m.ngeom):
            body = m.body(m.geom_bodyid[g]).name
            visual = m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0
            if not visual or m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH or body == "peg":
                continue
            k = m.geom_dataid[g]
            v = m.mesh_vert[m.mesh_vertadr[k] : m.mesh_vertadr[k] + m.mesh_vertnum[k]]
            f = m.mesh_face[m.mesh_faceadr[k] : m.mesh_faceadr[k] + m.mesh_facenum[k]]
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, m.geom_quat[g])
            v = v @ rot.reshape(3, 3).T + m.geom_pos[g]  # the mesh in its body's frame
            rgb = tuple(int(255 * c) for c in m.geom_rgba[g][:3])
            if m.geom_matid[g] >= 0:
                rgb = tuple(int(255 * c) for c in m.mat_rgba[m.geom_matid[g]][:3])
            out.append(LinkMesh(body, v.astype(np.float32), f.astype(np.int32), rgb))
        return out

    def pose(
        self, pos: np.ndarray, quat: np.ndarray, joints: np.ndarray | None = None
    ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Body name -> (position, quaternion wxyz), module frame, of every link with a
        mesh, with the peg at pos, quat: at `joints` where given, else carried there from
        the last pose shown (a pose out of reach keeps the closest the arm came)."""
        import mujoco

        from sim.robots.panda.kinematics import carry, place_peg

        m, d = self.model, self.data
        if joints is None:
            q, _ = carry(m, d, self.joints, np.asarray(pos, float), np.asarray(quat, float),
                         collide=False, margin=0.0)  # fmt: skip
            if q is None:
                q = place_peg(m, d, np.asarray(pos, float), np.asarray(quat, float), self.joints)[0]
            joints = q
        self.joints = np.asarray(joints, float).copy()
        d.qpos[:7] = self.joints
        mujoco.mj_kinematics(m, d)
        return {b: (d.xpos[m.body(b).id].copy(), d.xquat[m.body(b).id].copy())
                for b in self.bodies}  # fmt: skip
