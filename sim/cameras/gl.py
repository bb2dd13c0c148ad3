"""An offscreen OpenGL context for MuJoCo's renderer, on a machine with no display.

MuJoCo picks its GL backend from `MUJOCO_GL` when it is first imported, and falls back to GLFW,
which needs a display. The cameras choose for themselves, so they work whatever was imported
first: `MUJOCO_GL=egl` (the default here: Mesa's EGL renders on the CPU, or a GPU's driver
renders on it) or `MUJOCO_GL=osmesa` (Mesa's software rasteriser, slower). A backend that does
not start is one line naming the variable and the package to install: an image is never
silently black.
"""

from __future__ import annotations

import os
from typing import Any

BACKENDS = ("egl", "osmesa")
"""The headless backends a camera can use (MUJOCO_GL)."""
INSTALL = {
    "egl": "Mesa's EGL (Debian: apt install libegl1 libgl1-mesa-dri)",
    "osmesa": "OSMesa (Debian: apt install libosmesa6)",
}


class CameraError(RuntimeError):
    """No GL backend can render the cameras; the message says what to set or install."""


def backend() -> str:
    """The backend MUJOCO_GL names (default "egl"); CameraError for one a camera cannot use."""
    name = os.environ.get("MUJOCO_GL", "").strip().lower() or "egl"
    if name not in BACKENDS:
        raise CameraError(
            f"MUJOCO_GL={name!r} cannot render the cameras without a display: set MUJOCO_GL=egl "
            f"(needs {INSTALL['egl']}) or MUJOCO_GL=osmesa (needs {INSTALL['osmesa']})"
        )
    return name


def offscreen_context(width: int, height: int) -> Any:
    """A current GL context of MUJOCO_GL's backend (`.free()` releases it); CameraError naming
    the variable and the package where it does not start."""
    name = backend()
    # the backend modules read PYOPENGL_PLATFORM when PyOpenGL is first imported
    os.environ.setdefault("PYOPENGL_PLATFORM", name)
    try:
        if name == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.osmesa import GLContext
        ctx = GLContext(width, height)
        ctx.make_current()
    except Exception as e:  # every backend fails in its own way
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise CameraError(
            f"MUJOCO_GL={name}: no GL context ({first}); install {INSTALL[name]}, or set "
            f"MUJOCO_GL={'osmesa' if name == 'egl' else 'egl'} to try the other backend"
        ) from e
    return ctx
