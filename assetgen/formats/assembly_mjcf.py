"""MJCF of an assembly: the base's convex pieces static, each moving part a free body made of
its convex pieces, every step's frames as sites. Self-contained (inline meshes, as the
module's MJCF: assetgen.core.inline_mesh); SI units.

- Base pieces: contype 0, conaffinity 1 (they collide with the parts, not with each other).
  Moving parts: contype 1, conaffinity 1, so they collide with the base and with each other;
  MuJoCo never collides geoms of one body.
- Body `<part>` (free joint `<part>_free`) has the part frame as its frame, at the part's
  design pose; its inertia is given explicitly (mass, COM, inertia about the COM).
- Sites: `origin` (the module frame), `entrance_<part>` and `bottom_<part>` for each step,
  and `<part>_frame` on each part at its frame origin. `<numeric name="clearance_<part>">`
  holds each step's clearance and `<text name="steps">` the insertion order.
- Each part carries the simulator's six velocity actuators (`<part>_vel0` .. `_vel5`, on
  `<part>_frame`, against `origin`); with command 0 they hold the part as the task's
  controller does.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from assetgen.core.frames import Frame
from assetgen.core.inline_mesh import mesh_element, stored
from assetgen.core.inline_mesh import part_piece_name as mesh_name
from assetgen.core.mass_properties import MassProperties
from assetgen.core.mesh import Mesh
from assetgen.core.mujoco_config import (
    PhysicsConfig,
    actuator_xml,
    geom_default_xml,
    option_xml,
    physics_for,
    physics_version_xml,
    velocity_gains,
)
from assetgen.core.xml_text import xml_number, xml_vector
from assetgen.families.parts import Assembly
from assetgen.formats.mjcf import ORIGIN_SITE, verified_model

BASE = "base"


def _frame_attrs(frame: Frame) -> str:
    return f'pos="{xml_vector(frame.pos)}" quat="{xml_vector(frame.quat)}"'


def assembly_mjcf(
    assembly: Assembly,
    pieces: Mapping[str, Sequence[Mesh]],
    mass: Mapping[str, tuple[float, np.ndarray, np.ndarray]],
    contact: PhysicsConfig | None = None,
    name: str = "the assembly MJCF",
) -> bytes:
    """The assembly's MJCF as bytes, read back and compiled in MuJoCo before it is returned.

    pieces : every part's convex pieces in its part frame (m), the base's included.
    mass   : per moving part (kg, COM (3,) m, inertia (3, 3) kg m^2 about the COM), part frame.
    contact: the MuJoCo configuration; None: the simulator's for the finest clearance of the
    assembly's steps (assetgen.core.mujoco_config.physics_for).
    Raises ValueError naming the mesh or value (a piece not closed and convex, inline data
    that does not read back, a model MuJoCo refuses).
    """
    finest = min(s.clearance for s in assembly.steps)
    contact = (contact or physics_for(finest)).validate()
    order = [BASE, *(p.name for p in assembly.parts)]
    meshes = {n: stored(pieces[n]) for n in order}
    lines = [
        f'<mujoco model="{"-".join(order[1:])}">',
        "  <!-- assetgen: units m, kg, s; the inline meshes are millimetres (scale 0.001).",
        "       Module frame = world frame; each part body has its part frame as its frame. -->",
        '  <compiler angle="radian" inertiafromgeom="false"/>',
        *option_xml(contact),
        "  <custom>",
        *(
            f'    <numeric name="clearance_{s.part}" data="{xml_number(s.clearance)}"/>'
            for s in assembly.steps
        ),
        f'    <text name="steps" data="{" ".join(s.part for s in assembly.steps)}"/>',
        physics_version_xml(),
        "  </custom>",
        "  <default>",
        f'    <geom type="mesh" {geom_default_xml(contact)}/>',
        '    <site size="0.0005" rgba="1 0.3 0.1 1"/>',
        '    <default class="base">',
        '      <geom contype="0" conaffinity="1" group="1" rgba="0.6 0.6 0.65 1"/>',
        "    </default>",
        '    <default class="part">',
        '      <geom contype="1" conaffinity="1" priority="1" rgba="0.2 0.5 0.9 1"/>',
        "    </default>",
        "  </default>",
        "  <asset>",
    ]
    for part in order:
        lines += ["    " + mesh_element(mesh_name(part, i), m) for i, m in enumerate(meshes[part])]
    lines += ["  </asset>", "  <worldbody>", f'    <site name="{ORIGIN_SITE}" pos="0 0 0"/>']
    for s in assembly.steps:
        lines.append(f'    <site name="entrance_{s.part}" {_frame_attrs(s.entrance)}/>')
        lines.append(f'    <site name="bottom_{s.part}" {_frame_attrs(s.bottom)}/>')
    lines += [
        f'    <geom name="{mesh_name(BASE, i)}" class="base" mesh="{mesh_name(BASE, i)}"/>'
        for i in range(len(meshes[BASE]))
    ]
    actuators = []
    for part in assembly.parts:
        m, com, inertia = mass[part.name]
        props = MassProperties.checked(m, com, inertia, part.name)
        com, inertia = props.com, props.inertia
        full = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2],
                inertia[1, 2]]  # fmt: skip
        pose = Frame.from_matrix(part.pose)
        lines += [
            f'    <body name="{part.name}" {_frame_attrs(pose)}>',
            f'      <freejoint name="{part.name}_free"/>',
            f'      <inertial pos="{xml_vector(com)}" mass="{xml_number(m)}" '
            f'fullinertia="{xml_vector(full)}"/>',
            *(
                f'      <geom name="{mesh_name(part.name, i)}" class="part" '
                f'mesh="{mesh_name(part.name, i)}"/>'
                for i in range(len(meshes[part.name]))
            ),
            f'      <site name="{part.name}_frame" pos="0 0 0"/>',
            "    </body>",
        ]
        kv_lin, kv_rot = velocity_gains(float(m), com, inertia, contact, portable=True)
        actuators += actuator_xml(
            f"{part.name}_frame", ORIGIN_SITE, kv_lin, kv_rot, prefix=f"{part.name}_",
            block=False,
        )  # fmt: skip
    lines += ["  </worldbody>", "  <actuator>", *actuators, "  </actuator>", "</mujoco>", ""]
    text = "\n".join(lines)
    model = verified_model(
        text, {mesh_name(p, i): m for p in order for i, m in enumerate(meshes[p])}, name
    )
    for part in assembly.parts:
        body = model.body(part.name)
        if np.abs(body.pos - part.pose[:3, 3]).max() > 1e-12:
            raise ValueError(f"{name}: body {part.name!r} compiled at {body.pos}, not its pose")
    return text.encode("utf-8")
