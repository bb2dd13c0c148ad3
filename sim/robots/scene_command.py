"""`assetgen scene MODULE --robot panda --out DIR`: one MJCF file with the robot, the module
and the peg in its hand, which loads in MuJoCo on its own (the arm's meshes are copied beside
it, into DIR/meshes, from the installed package: the user's folder, never this repository).
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

SCENE_FILE = "scene.xml"


def add_parser(sub: argparse._SubParsersAction) -> None:
    from sim.robots.registry import robot_names

    p = sub.add_parser("scene", help="write one MJCF scene: a robot holding a module's peg")
    p.add_argument("module", help="a module's folder, or its id in --dataset")
    p.add_argument("--dataset", default="test", help="where to find a module id (test)")
    p.add_argument("--robot", choices=robot_names(), required=True, help="the robot")
    p.add_argument("--out", required=True, help="the folder to write scene.xml and meshes/ to")
    p.set_defaults(func=main)


def _module_dir(module: str, dataset: str) -> Path:
    from sim.assets.loading import dataset_root

    given = Path(module)
    if (given / "module.json").is_file():
        return given
    folder = dataset_root(dataset) / "modules" / module
    if not (folder / "module.json").is_file():
        raise ValueError(
            f"{module}: neither a module folder (with module.json) nor a module of dataset "
            f"{dataset!r}; give a folder, or an id with --dataset NAME"
        )
    return folder


def write_scene(module_dir: Path, robot: str, out: Path) -> Path:
    """Write `out`/scene.xml and the robot's meshes beside it; returns the file's path."""
    import mujoco

    from assetgen.core.atomic_file import write_text
    from assetgen.core.mujoco_config import physics_for
    from sim.assets.loading import load_module
    from sim.robots.registry import get_robot

    build = get_robot(robot).load("scene")
    asset = load_module(module_dir)
    spec = build(asset, physics_for(asset.clearance))
    spec.modelname = f"{robot}_{asset.id}"
    meshes = out / "meshes"
    meshes.mkdir(parents=True, exist_ok=True)
    copies = {}
    for mesh in spec.meshes:
        if mesh.file:
            src = Path(mesh.file)
            name = f"{src.parent.name}_{src.name}"  # visual/link0.stl -> visual_link0.stl
            shutil.copyfile(src, meshes / name)
            copies[str(src)] = f"meshes/{name}"
    spec.compile()  # to_xml needs a compiled spec
    xml = spec.to_xml()
    for src, rel in copies.items():  # beside the file: it loads from anywhere
        xml = xml.replace(f'file="{src}"', f'file="{rel}"')
    path = write_text(out / SCENE_FILE, xml)
    mujoco.MjModel.from_xml_path(str(path))  # it loads on its own
    return path


def main(args: argparse.Namespace) -> int:
    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import PreflightError, check_output_folder

    try:  # a missing [robot] extra is a project error: one line at the entry point
        check_output_folder(args.out, "--out")
        path = write_scene(_module_dir(args.module, args.dataset), args.robot, Path(args.out))
    except (ValueError, PreflightError) as e:
        return print_error(str(e))
    print(f"wrote {path} (open it with: python -m mujoco.viewer --mjcf={path})")
    return 0
