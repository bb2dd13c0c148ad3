"""A picture of one assembly for the README: each part from its own STL, exploded along its
insertion axis (the profile above its socket, the bolt out to the side).

    python -m benchmarks.assembly_picture [--dataset assembly_test] [--module 000000]
                                          [--out docs/images/assembly.png]

Reads only the module's files (module.json and the parts' STL); needs matplotlib (the `[rl]`
extra). Shading is Lambertian per triangle, light from the viewer's upper left.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from assetgen.core.stl import read_stl_mm
from assetgen.dataset.spec import resolve
from sim.assets.loading import frame_matrix

COLOURS = {"base": (0.72, 0.74, 0.78), "profile": (0.85, 0.55, 0.25), "bolt": (0.35, 0.5, 0.8)}


def _shaded(tris: np.ndarray, colour: tuple[float, float, float], light: np.ndarray):
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-30
    k = 0.35 + 0.65 * np.clip(n @ light, 0.0, 1.0)
    return np.clip(np.outer(k, colour), 0.0, 1.0)


def _split(tris: np.ndarray, longest: float) -> np.ndarray:
    """Triangles (n, 3, 3) halved across their longest edge until no edge is longer than
    `longest`: matplotlib orders polygons by their mean depth, which long slivers defeat."""
    done = []
    while len(tris):
        edge = np.linalg.norm(tris[:, [1, 2, 0]] - tris, axis=2)  # edge k: corner k to k+1
        long = edge.max(axis=1) > longest
        done.append(tris[~long])
        t, k = tris[long], edge[long].argmax(axis=1)
        i = np.arange(len(t))
        a, b, c = t[i, k], t[i, (k + 1) % 3], t[i, (k + 2) % 3]
        mid = (a + b) / 2
        tris = np.concatenate([np.stack([a, mid, c], 1), np.stack([mid, b, c], 1)])
    return np.concatenate(done)


def draw(module_dir: Path, out: Path, explode: float = 1.3) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    meta = json.loads((module_dir / "module.json").read_text())
    fig = plt.figure(figsize=(8, 6), dpi=120)
    ax = fig.add_subplot(projection="3d")
    ax.view_init(elev=24, azim=-58)
    light = np.array([-0.4, -0.6, 0.7])
    light /= np.linalg.norm(light)
    parts = {"base": np.eye(4)}
    for s in meta["steps"]:
        pose = frame_matrix(s["design_pose"], "design_pose", module_dir)
        entrance = frame_matrix(s["entrance"], "entrance", module_dir)
        bottom = frame_matrix(s["bottom"], "bottom", module_dir)
        out_dir = entrance[:3, 3] - bottom[:3, 3]
        out_dir /= np.linalg.norm(out_dir)
        lifted = pose.copy()
        lifted[:3, 3] += explode * s["travel_m"] * out_dir
        parts[s["part"]] = lifted
    everything = []
    window = None
    for name, pose in parts.items():
        mesh = read_stl_mm(module_dir / f"{name}.stl")
        v = mesh.vertices @ pose[:3, :3].T + pose[:3, 3]
        tris = v[mesh.faces] * 1e3  # mm
        if name == "base":
            # the 150 mm plate would dwarf the block: keep the block and a tile of plate
            block = tris[(tris[..., 2] > 1e-6).any(axis=1)]
            r = np.abs(block[..., :2]).max() + 15.0
            window = r
            tile = np.array([[[-r, -r, 0.0], [r, -r, 0.0], [r, r, 0.0]],
                             [[-r, -r, 0.0], [r, r, 0.0], [-r, r, 0.0]]])  # fmt: skip
            tris = np.concatenate([block, tile])
        else:
            everything.append(tris.reshape(-1, 3))
        tris = _split(tris, 4.0)
        colours = _shaded(tris, COLOURS.get(name, (0.6,) * 3), light)
        ax.add_collection3d(
            Poly3DCollection(tris, facecolors=colours, edgecolors=colours, linewidths=0.3)
        )
    assert window is not None
    pts = np.vstack([*everything, [[-window, -window, 0.0], [window, window, 0.0]]])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, half = (lo + hi) / 2, 0.4 * (hi - lo).max()
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, strict=True):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_axis_off()
    p = meta["params"]
    ax.set_title(
        f"assembly {meta['id']}: profile {p['profile_side'] * 1e3:.1f} mm"
        f"{' with T-slots' if p['slots'] else ''} at {p['profile_clearance'] * 1e3:g} mm, "
        f"bolt M{p['bolt_diameter'] * 1e3:.1f} at {p['bolt_clearance'] * 1e3:g} mm",
        fontsize=10,
    )
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp.png")
    fig.savefig(tmp)
    tmp.replace(out)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dataset", default="assembly_test", help="a dataset name or folder")
    p.add_argument("--module", default="000000", help="the assembly's id")
    p.add_argument("--out", default="docs/images/assembly.png", type=Path)
    a = p.parse_args()
    root = resolve(a.dataset)[0]
    draw(root / "modules" / a.module, a.out)
    print(a.out)


if __name__ == "__main__":
    main()
