"""Camera images of modules and their pegs, rendered by MuJoCo's renderer offscreen.

The cameras read what every engine shares, the modules and the pegs' poses, and not an
engine's own models, so they draw the same for every engine and robot (a robot's links are not
drawn yet). Each module gets a small model of its own to draw from: its collision pieces (their
union is the module; MuJoCo draws each piece's convex hull) and its peg's surface on a mocap
body carrying the wrist camera, lit from above, with no shadows and no multisampling (an image
costs 1–3 ms at 64 x 64 on one core). Its GPU-side context is built at its first image and
kept, up to `cache` modules, so envs that take modules in turns pay for a module once.
"""

from __future__ import annotations

from collections import OrderedDict

import mujoco
import numpy as np

from sim.assets.loading import ModuleAsset
from sim.cameras.config import CameraConfig
from sim.cameras.gl import offscreen_context

PLATE_RGBA = (0.62, 0.64, 0.68, 1.0)
PEG_RGBA = (0.85, 0.45, 0.2, 1.0)


def _numbers(a: np.ndarray) -> str:
    return " ".join(repr(float(x)) for x in np.asarray(a, dtype=float).ravel())


def _xyaxes(position: np.ndarray, target: np.ndarray) -> np.ndarray:
    """MuJoCo's camera axes (its x and y; it looks along -z) for a camera at `position`
    looking at `target`, with the image's up as near the frame's +z as the view allows (+y
    where the view is along z)."""
    forward = (target - position) / np.linalg.norm(target - position)
    up = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < 0.999 else np.array([0.0, 1.0, 0.0])
    x = np.cross(forward, up)
    x /= np.linalg.norm(x)
    return np.concatenate([x, np.cross(x, forward)])


def camera_xml(asset: ModuleAsset, cfg: CameraConfig) -> str:
    """The MJCF of the model a camera draws `asset` from (see the module doc)."""
    top = float(asset.peg.vertices[:, 2].max())
    if cfg.view == "wrist":
        pos = np.array(cfg.wrist_offset) + np.array([0.0, 0.0, top])
        look = np.array([0.0, 0.0, -cfg.wrist_look_below])
    else:
        pos, look = np.array(cfg.fixed_position), np.array(cfg.fixed_target)
    camera = (
        f'<camera name="view" pos="{_numbers(pos)}" xyaxes="{_numbers(_xyaxes(pos, look))}" '
        f'fovy="{cfg.fovy!r}"/>'
    )
    meshes = "".join(
        f'<mesh name="piece{i}" vertex="{_numbers(p.vertices)}"/>'
        for i, p in enumerate(asset.pieces)
    )
    faces = " ".join(str(int(i)) for i in asset.peg.faces.ravel())
    meshes += f'<mesh name="peg" vertex="{_numbers(asset.peg.vertices)}" face="{faces}"/>'
    pieces = "".join(
        f'<geom type="mesh" mesh="piece{i}" rgba="{_numbers(PLATE_RGBA)}"/>'
        for i in range(len(asset.pieces))
    )
    return (
        f'<mujoco model="camera {asset.id}"><compiler boundmass="1e-6" boundinertia="1e-12"/>'
        f'<statistic extent="1" center="0 0 0"/>'
        f'<visual><quality shadowsize="0" offsamples="0"/>'
        f'<global offwidth="{cfg.width}" offheight="{cfg.height}"/>'
        f'<map znear="{cfg.near!r}" zfar="{cfg.far!r}"/>'
        f'<headlight ambient="0.3 0.3 0.3" diffuse="0.4 0.4 0.4"/></visual>'
        f"<asset>{meshes}</asset><worldbody>"
        f'<light pos="0 0 1" dir="0 0 -1" castshadow="false" diffuse="0.5 0.5 0.5"/>'
        f"{pieces if cfg.view == 'wrist' else pieces + camera}"
        f'<body name="peg" mocap="true"><geom type="mesh" mesh="peg" '
        f'rgba="{_numbers(PEG_RGBA)}" contype="0" conaffinity="0"/>'
        f"{camera if cfg.view == 'wrist' else ''}</body></worldbody></mujoco>"
    )


class _Scene:
    """One module's model, data and GPU-side context."""

    def __init__(self, asset: ModuleAsset, cfg: CameraConfig) -> None:
        self.model = mujoco.MjModel.from_xml_string(camera_xml(asset, cfg))
        self.data = mujoco.MjData(self.model)
        self.context = mujoco.MjrContext(self.model, mujoco.mjtFontScale.mjFONTSCALE_100)

    def free(self) -> None:
        self.context.free()


class CameraRenderer:
    """Images of `cfg`'s camera for modules `assets` (indexed as the env indexes its modules):
    `render(modules, peg_pos, peg_quat)` -> (k, channels, height, width) float32, noise-free
    (sim.cameras.noise adds the sensor's)."""

    def __init__(self, assets: list[ModuleAsset], cfg: CameraConfig, cache: int = 64) -> None:
        self.cfg = cfg.validate()
        self.assets = assets
        self.cache = max(1, int(cache))
        self._gl = offscreen_context(cfg.width, cfg.height)
        self._scenes: OrderedDict[int, _Scene] = OrderedDict()
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._camera.fixedcamid = 0
        self._viewport = mujoco.MjrRect(0, 0, cfg.width, cfg.height)
        self._rgb = np.empty((cfg.height, cfg.width, 3), dtype=np.uint8)
        self._depth = np.empty((cfg.height, cfg.width), dtype=np.float32)
        self._vscene: mujoco.MjvScene | None = None

    def _scene(self, k: int) -> _Scene:
        scene = self._scenes.get(k)
        if scene is None:
            self._gl.make_current()
            scene = self._scenes[k] = _Scene(self.assets[k], self.cfg)
            if len(self._scenes) > self.cache:
                self._scenes.popitem(last=False)[1].free()
        else:
            self._scenes.move_to_end(k)
        return scene

    def render(self, modules: np.ndarray, peg_pos: np.ndarray, peg_quat: np.ndarray) -> np.ndarray:
        """(k, channels, height, width) float32 images of modules[i] (indices into assets)
        with their pegs at peg_pos[i] (m) and peg_quat[i] (w, x, y, z), module frame."""
        cfg = self.cfg
        out = np.empty((len(modules), *cfg.shape), dtype=np.float32)
        want_rgb = cfg.modality != "depth"
        want_depth = cfg.modality != "rgb"
        near, far = cfg.near, cfg.far
        self._gl.make_current()
        for i, k in enumerate(np.asarray(modules).tolist()):
            s = self._scene(k)
            s.data.mocap_pos[0] = peg_pos[i]
            s.data.mocap_quat[0] = peg_quat[i]
            mujoco.mj_kinematics(s.model, s.data)
            mujoco.mj_camlight(s.model, s.data)
            if self._vscene is None:
                self._vscene = mujoco.MjvScene(s.model, maxgeom=10_000)
            mujoco.mjv_updateScene(s.model, s.data, self._option, self._perturb, self._camera,
                                   mujoco.mjtCatBit.mjCAT_ALL, self._vscene)  # fmt: skip
            # each module's context has its own offscreen buffer: draw into and read from it
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, s.context)
            mujoco.mjr_render(self._viewport, self._vscene, s.context)
            mujoco.mjr_readPixels(self._rgb if want_rgb else None,
                                  self._depth if want_depth else None, self._viewport,
                                  s.context)  # fmt: skip
            c = 0
            if want_rgb:  # OpenGL's rows run bottom-up; images run top-down
                out[i, :3] = self._rgb[::-1].transpose(2, 0, 1) / np.float32(255.0)
                c = 3
            if want_depth:
                # the depth buffer's [0, 1] back to z-depth in metres (near, far in metres:
                # the model's extent is 1)
                z = near / (1.0 - self._depth[::-1] * (1.0 - near / far))
                out[i, c] = np.minimum(z, far)
        return out

    def close(self) -> None:
        """Release the GPU-side contexts and the GL context."""
        for s in self._scenes.values():
            s.free()
        self._scenes.clear()
        self._gl.free()
