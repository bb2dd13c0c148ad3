"""Blender's bare generation against this generator, per module and per core, in one run.

    python -m benchmarks.blender_baseline --python BLENDER_PYTHON [--n 128]

BLENDER_PYTHON is a Python interpreter with Blender as a module (`bpy` from PyPI, about
0.5 GB; keep it in its own virtual environment: `python -m venv bpy-env &&
bpy-env/bin/pip install bpy==4.2.0`). Nothing here is a dependency of the project.

Blender's side is the core of a Blender pipeline like the paper's, and nothing more: for
each module of Table I (the same parameters this generator samples, seeds 0 .. n-1), the
peg as a prism from its section (tapered as sampled), a 15 x 15 cm plate, a hole cutter
(the peg's section grown by the clearance, placed and tilted as the hole), one exact
boolean difference, and two STL files. No sleeve under the plate, no check, no collision
pieces, no MJCF, USD or 3MF. Its hole is not exact: growing a section by scaling it moves
each face by less than the clearance where the section is squashed.

This generator's side is `assetgen bench assets --workers 1` on the same seeds: every
format and every check, one process. Both run one after the other on one core; the ratio
is their time per module.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

BLENDER_SCRIPT = r"""
import json, math, sys, time
import bpy  # first: it makes bmesh importable
import bmesh

params, out = json.load(open(sys.argv[1])), sys.argv[2]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def prism(name, bottom, top, z0, z1):
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    lo = [bm.verts.new((x, y, z0)) for x, y in bottom]
    hi = [bm.verts.new((x, y, z1)) for x, y in top]
    bm.faces.new(lo[::-1])
    bm.faces.new(hi)
    n = len(lo)
    for i in range(n):
        j = (i + 1) % n
        bm.faces.new((lo[i], lo[j], hi[j], hi[i]))
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def export(obj, path):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.wm.stl_export(filepath=path, export_selected_objects=True, ascii_format=False)


times = []
for i, p in enumerate(params):
    t0 = time.perf_counter()
    top, taper, h, c = p["section"], p["taper"], p["peg_height"], p["clearance"]
    bottom = [((1 - taper) * x, (1 - taper) * y) for x, y in top]
    peg = prism("peg", bottom, top, 0.0, h)
    r = max(math.hypot(x, y) for x, y in top)
    grow = (r + c) / r  # the cutter: the section scaled out by the clearance
    cutter = prism(
        "cutter",
        [(grow * x, grow * y) for x, y in bottom],
        [(grow * x, grow * y) for x, y in top],
        -c,
        h + 0.05,
    )
    cutter.matrix_world = [list(row) for row in p["bottom_matrix"]]
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    plate = bpy.context.active_object
    plate.scale = (p["plate_size"], p["plate_size"], p["plate_thickness"])
    plate.location = (0.0, 0.0, -p["plate_thickness"] / 2)
    mod = plate.modifiers.new("hole", "BOOLEAN")
    mod.operation, mod.solver, mod.object = "DIFFERENCE", "EXACT", cutter
    bpy.context.view_layer.objects.active = plate
    bpy.ops.object.modifier_apply(modifier="hole")
    export(peg, f"{out}/peg_{i}.stl")
    export(plate, f"{out}/module_{i}.stl")
    for obj in (peg, cutter, plate):
        mesh = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
    times.append(time.perf_counter() - t0)
print(json.dumps({"seconds": times}))
"""


def table_one_params(n: int) -> list[dict]:
    """The first n Table I modules' shapes and hole poses, as Blender's side needs them."""
    from assetgen.geometry.solids import cross_section, task_frames
    from assetgen.params.sampler import SamplerConfig, sample_params

    out = []
    for seed in range(n):
        p = sample_params(SamplerConfig(), seed)
        _, bottom, _ = task_frames(p)
        out.append(
            {
                "section": cross_section(p).tolist(),
                "taper": p.taper,
                "peg_height": p.peg_height,
                "clearance": p.clearance,
                "plate_size": p.plate_size,
                "plate_thickness": p.plate_thickness,
                "bottom_matrix": bottom.matrix().tolist(),
            }
        )
    return out


def blender_seconds(python: str, params: list[dict]) -> list[float]:
    """Blender's wall seconds for each module (the interpreter's start-up not counted)."""
    with tempfile.TemporaryDirectory(prefix=".blender-") as tmp:
        src, script = Path(tmp) / "params.json", Path(tmp) / "generate.py"
        src.write_text(json.dumps(params))
        script.write_text(BLENDER_SCRIPT)
        (Path(tmp) / "out").mkdir()
        run = subprocess.run(
            [python, str(script), str(src), str(Path(tmp) / "out")],
            capture_output=True,
            text=True,
        )
        if run.returncode != 0:
            raise SystemExit(f"{python} could not run Blender's side:\n{run.stderr[-2000:]}")
        last = [line for line in run.stdout.splitlines() if line.startswith('{"seconds"')]
        return json.loads(last[-1])["seconds"]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--python", required=True, help="a Python interpreter with bpy")
    p.add_argument("--n", type=int, default=128, help="modules (default 128)")
    p.add_argument("--json", help="also write the figures here")
    args = p.parse_args(argv)
    if args.n < 1:
        p.error(f"--n {args.n}: give at least 1 module")
    from assetgen.bench import bench_assets

    ours = bench_assets(args.n, workers=1)
    theirs = blender_seconds(args.python, table_one_params(args.n))
    ours_ms = 1e3 * ours["seconds"] / args.n
    blender_ms = 1e3 * sum(theirs) / len(theirs)
    figures = {
        "modules": args.n,
        "assetgen_ms_per_module": ours_ms,
        "blender_ms_per_module": blender_ms,
        "ratio": ours_ms / blender_ms,
        "assetgen_step_ms": ours["step_ms"],
    }
    print(f"{args.n} Table I modules, one process each, one after the other:")
    print(f"  assetgen (every format and check): {ours_ms:.2f} ms a module")
    print(f"  Blender (boolean + two STL files):  {blender_ms:.2f} ms a module")
    print(f"  ratio: {figures['ratio']:.2f}x")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
