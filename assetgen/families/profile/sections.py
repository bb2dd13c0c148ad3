"""The cross-sections of the `profile` family: non-convex shapes drawn from a generator.

Each function returns a simple counter-clockwise polygon (n, 2) in metres, `size` its
outer radius (the farthest vertex from its own centre before the family moves the area
centroid onto the peg's axis). Round boundaries are polygons with their vertices on the
circle (as Table I's 32-gon), so every face is planar and the clearance exact on it.
"""

from __future__ import annotations

import math

import numpy as np

from assetgen.core.portable import dot

ROUND_SIDES = 32
"""Vertices of a full circle (as Table I's "circle")."""


def _ccw(points: list[tuple[float, float]]) -> np.ndarray:
    return np.asarray(points, dtype=float)


def l_shape(size: float, arm: float) -> np.ndarray:
    """An L: a square of half-side a = size / sqrt(2) less its upper-right part, leaving two
    arms `arm` (fraction of the side) wide."""
    a = size / math.sqrt(2)
    w = 2 * a * arm
    return _ccw([(-a, -a), (a, -a), (a, -a + w), (-a + w, -a + w), (-a + w, a), (-a, a)])


def t_shape(size: float, arm: float) -> np.ndarray:
    """A T: a bar across the top of a square of half-side a = size / sqrt(2) and a stem
    down its middle, both `arm` (fraction of the side) wide."""
    a = size / math.sqrt(2)
    w = 2 * a * arm
    s = w / 2
    return _ccw(
        [(-s, -a), (s, -a), (s, a - w), (a, a - w), (a, a), (-a, a), (-a, a - w), (-s, a - w)]
    )


def cross_shape(size: float, arm: float) -> np.ndarray:
    """A plus sign: two bars across each other, their end corners on the outer radius, each
    `arm` times its length wide."""
    a = size / math.sqrt(1 + arm**2)  # the arm's end corners lie on the outer radius
    s = a * arm  # half the width: the bar is 2 a long and 2 a arm wide
    quarter = [(a, -s), (a, s), (s, s)]
    pts: list[tuple[float, float]] = []
    for k in range(4):
        c, n = math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)
        pts += [(c * x - n * y, n * x + c * y) for x, y in quarter]
    return _ccw(pts)


def star(size: float, points: int, inner: float) -> np.ndarray:
    """An n-pointed star: tips on the outer radius, notches at `inner` times it."""
    k = np.arange(2 * points)
    r = np.where(k % 2 == 0, size, inner * size)
    theta = math.pi * k / points
    return np.column_stack([r * np.cos(theta), r * np.sin(theta)])


def keyed_round(size: float, key: str, width: float, depth: float) -> np.ndarray:
    """A round shaft (vertices on the circle) with a flat (`key` "flat": a chord `depth`
    times the radius in from the rim; convex, a D-shaft) or a keyway ("keyway": a slot
    `width` times the diameter wide and `depth` times the radius deep), on its +x side."""
    if key == "flat":
        theta0 = math.acos(1 - depth)
        slot: list[tuple[float, float]] = []
    elif key == "keyway":
        half = width * size
        theta0 = math.asin(half / size)
        x = size - depth * size
        slot = [(x, -half), (x, half)]
    else:
        raise ValueError(f"key = {key!r}: give 'flat' or 'keyway'")
    sides = math.ceil(ROUND_SIDES * (2 * math.pi - 2 * theta0) / (2 * math.pi))
    theta = np.linspace(theta0, 2 * math.pi - theta0, sides + 1)
    arc = np.column_stack([size * np.cos(theta), size * np.sin(theta)])
    return np.vstack([arc, np.asarray(slot, dtype=float).reshape(-1, 2)])


def spline_shaft(size: float, teeth: int, depth: float) -> np.ndarray:
    """A splined shaft: `teeth` parallel-sided teeth standing on a root circle of `1 - depth`
    times the outer radius, each as wide as the gap between two at the root. The root
    between two teeth is flat (a chord), and each tooth's top too: four vertices a tooth,
    which keeps the hole's convex pieces few."""
    root = (1 - depth) * size
    half = root * math.sin(math.pi / (2 * teeth))  # half a tooth's width
    a_root, a_tip = math.asin(half / root), math.asin(half / size)
    pts: list[tuple[float, float]] = []
    for k in range(teeth):
        phi = 2 * math.pi * k / teeth
        for r, a in (
            (root, phi - a_root),
            (size, phi - a_tip),
            (size, phi + a_tip),
            (root, phi + a_root),
        ):
            pts.append((r * math.cos(a), r * math.sin(a)))
    return _ccw(pts)


def random_polygon(
    rng: np.random.Generator, size: float, vertices: int, low: float, max_reflex: float
) -> np.ndarray:
    """A random simple polygon, star-shaped about its centre: `vertices` angles jittered
    about even spacing, radii uniform in [low, 1] times `size`, redrawn (up to 1000 times)
    until no reflex corner exceeds `max_reflex` (rad) and no corner is sharper than 30 deg."""
    for _ in range(1000):
        base = 2 * math.pi * np.arange(vertices) / vertices
        theta = base + rng.uniform(-0.3, 0.3, vertices) * 2 * math.pi / vertices
        r = size * rng.uniform(low, 1.0, vertices)
        poly = np.column_stack([r * np.cos(theta), r * np.sin(theta)])
        angles = interior_angles(poly)
        if angles.max() <= max_reflex and angles.min() >= math.radians(30):
            return poly
    raise ValueError(
        f"no random polygon of {vertices} vertices with reflex corners below "
        f"{math.degrees(max_reflex):g} deg in 1000 draws: raise max_reflex or the radius floor"
    )


def interior_angles(poly: np.ndarray) -> np.ndarray:
    """Interior angle (rad, in (0, 2 pi)) at each vertex of a counter-clockwise polygon."""
    a = np.roll(poly, 1, axis=0) - poly
    b = np.roll(poly, -1, axis=0) - poly
    turn = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], dot(a, b))
    # the angle from b round to a, counter-clockwise, is the interior one
    return np.mod(-turn, 2 * math.pi)
