"""viser scene nodes for a module, its section cut, an episode path and the grid layout.

Shared by the live viewer (server.py) and the HTML snapshot (snapshot.py). All positions are
metres in the module frame (the world frame of the viewer for a single module).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import viser

from preview.scene import ModuleView, Section

BODY_COLOR = (190, 192, 200)
PEG_COLOR = (235, 130, 45)
SECTION_BODY_COLOR = (120, 150, 200)
OUTLINE_COLOR = (20, 20, 20)
PATH_COLOR = (40, 160, 90)
OBSERVED_COLOR = (30, 90, 230)
"""The peg at its observed (noisy) pose: a blue wireframe, so the true peg stays visible
(the two are a millimetre apart at most, mostly)."""
PIECE_COLORS = (
    (230, 25, 75),
    (60, 180, 75),
    (255, 225, 25),
    (0, 130, 200),
    (245, 130, 48),
    (145, 30, 180),
    (70, 240, 240),
    (240, 50, 230),
    (210, 245, 60),
    (0, 128, 128),
)
FRAME_AXES_M = 0.02
"""Axis length of the entrance / bottom frame triads, metres."""

CAMERA_POSITION = (0.13, -0.17, 0.12)
"""Default camera position, metres: above and in front of the 15 cm plate."""
CAMERA_LOOK_AT = (0.0, 0.0, -0.02)


def configure_camera(server: viser.ViserServer) -> None:
    """Initial camera framing a 15 cm module (also stored in HTML snapshots)."""
    server.scene.set_up_direction("+z")
    server.initial_camera.position = CAMERA_POSITION
    server.initial_camera.look_at = CAMERA_LOOK_AT
    server.initial_camera.near = 0.002
    server.initial_camera.far = 50.0


def add_module(
    scene: viser.SceneApi,
    view: ModuleView,
    prefix: str = "/module",
    *,
    collision: bool = True,
    frames: bool = True,
    position: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.0),
) -> dict[str, Any]:
    """Module body, peg (at the design pose), collision pieces (hidden) and the entrance and
    bottom frames under `prefix`, placed at `position` (metres). Returns handles by name."""
    h: dict[str, Any] = {}
    h[prefix] = scene.add_frame(prefix, show_axes=False, position=np.asarray(position, float))
    b = view.body
    h[f"{prefix}/body"] = scene.add_mesh_simple(
        f"{prefix}/body", b.vertices, b.faces, color=BODY_COLOR, flat_shading=True
    )
    pos, quat = view.peg_pose(0.0)
    p = view.peg
    h[f"{prefix}/peg"] = scene.add_mesh_simple(
        f"{prefix}/peg",
        p.vertices,
        p.faces,
        color=PEG_COLOR,
        flat_shading=True,
        position=pos,
        wxyz=quat,
    )
    if collision:
        h[f"{prefix}/collision"] = scene.add_frame(
            f"{prefix}/collision", show_axes=False, visible=False
        )
        for i, piece in enumerate(view.collision):
            name = f"{prefix}/collision/piece_{i:03d}"
            h[name] = scene.add_mesh_simple(
                name,
                piece.vertices,
                piece.faces,
                color=PIECE_COLORS[i % len(PIECE_COLORS)],
                opacity=0.55,
                flat_shading=True,
            )
    if frames:
        for key in ("entrance", "bottom"):
            f = view.frames[key]
            h[f"{prefix}/{key}"] = scene.add_frame(
                f"{prefix}/{key}",
                axes_length=FRAME_AXES_M,
                axes_radius=FRAME_AXES_M / 30,
                origin_radius=FRAME_AXES_M / 15,
                position=np.asarray(f.pos),
                wxyz=np.asarray(f.quat),
            )
    return h


def add_arm(scene: viser.SceneApi, arm: Any, prefix: str = "/module/arm") -> dict[str, Any]:
    """A robot's links (preview.arm.ArmView) under `prefix`: a frame a link, posed by
    `pose_arm`, holding its meshes. Returns handles by name."""
    h: dict[str, Any] = {prefix: scene.add_frame(prefix, show_axes=False)}
    for i, link in enumerate(arm.links):
        name = f"{prefix}/{link.body}"
        if name not in h:
            h[name] = scene.add_frame(name, show_axes=False)
        h[f"{name}/mesh{i}"] = scene.add_mesh_simple(
            f"{name}/mesh{i}", link.vertices, link.faces, color=link.rgb, flat_shading=False
        )
    return h


def pose_arm(
    handles: dict[str, Any], poses: dict[str, tuple[np.ndarray, np.ndarray]],
    prefix: str = "/module/arm",
) -> None:  # fmt: skip
    """Move the links' frames to `poses` (body name -> position, quaternion wxyz)."""
    for body, (pos, quat) in poses.items():
        frame = handles.get(f"{prefix}/{body}")
        if frame is not None:
            frame.position = pos
            frame.wxyz = quat


def add_observed_peg(
    scene: viser.SceneApi, view: ModuleView, name: str = "/module/observed"
) -> Any:
    """A second peg for the pose a policy observes (hidden until placed by a live run)."""
    pos, quat = view.peg_pose(0.0)
    p = view.peg
    return scene.add_mesh_simple(
        name,
        p.vertices,
        p.faces,
        color=OBSERVED_COLOR,
        wireframe=True,
        cast_shadow=False,
        position=pos,
        wxyz=quat,
        visible=False,
    )


def add_section(
    scene: viser.SceneApi, section: Section, prefix: str = "/section", *, visible: bool = True
) -> dict[str, Any]:
    """The two capped halves and the cut outline of a section under `prefix`."""
    h: dict[str, Any] = {}
    h[prefix] = scene.add_frame(prefix, show_axes=False, visible=visible)
    for part, mesh, color in (
        ("body", section.body, SECTION_BODY_COLOR),
        ("peg", section.peg, PEG_COLOR),
    ):
        if len(mesh.faces):  # the peg may lie wholly on the cut-away side (episode poses)
            h[f"{prefix}/{part}"] = scene.add_mesh_simple(
                f"{prefix}/{part}",
                mesh.vertices,
                mesh.faces,
                color=color,
                flat_shading=True,
                side="double",
            )
    if len(section.outline):
        # Nudged 0.1 mm towards the viewer's side of the cut so the lines are not z-fought by
        # the cap faces lying in the same plane.
        h[f"{prefix}/outline"] = scene.add_line_segments(
            f"{prefix}/outline",
            section.outline - 1e-4 * section.normal,
            OUTLINE_COLOR,
            thickness=2.0,
            thickness_units="screen",
        )
    return h


def add_path(scene: viser.SceneApi, positions: np.ndarray, name: str = "/episode/path") -> Any:
    """The peg frame's path (T, 3) metres as line segments."""
    pts = np.asarray(positions, dtype=np.float64)
    if len(pts) < 2:
        pts = np.concatenate([pts, pts])
    segs = np.stack([pts[:-1], pts[1:]], axis=1)
    return scene.add_line_segments(name, segs, PATH_COLOR, thickness=2.0, thickness_units="screen")
