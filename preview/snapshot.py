"""Self-contained HTML snapshots of a module (and an episode) that open without a server.

viser 1.1 ships its built client as one self-contained file (viser/client/build/index.html,
about 0.8 MB, three.js and React included, nothing fetched from the network) and can embed a
serialized scene into it: `ViserServer.get_scene_serializer().as_html()` puts the
zstd-compressed scene messages into `window.__VISER_EMBED_DATA__` as base64. We build the
scene on a throw-away loopback server, record it (for an episode: one pose update per step
with `insert_sleep(dt)` between, which the embedded client replays with its own play / pause
/ scrub bar), and add a small static panel with the module's parameters. The offline client
has a scene-tree panel (top right) whose eye icons toggle peg, module, collision pieces,
frames and the (initially hidden) section cut.
"""

from __future__ import annotations

import html
from pathlib import Path

from assetgen.core.atomic_file import write_text
from preview import nodes
from preview.episode import Episode, fit_notes, load_episode
from preview.scene import ModuleView, PreviewError, normalise_id, open_dataset
from preview.server import start_server, stop_server


def _status(ep: Episode, k: int) -> str:
    end = k == ep.steps - 1
    outcome = ("   ended: success" if ep.success else "   ended: no success") if end else ""
    return (
        f"t = {k * ep.dt:.2f} s   reward {ep.reward[k]:+.3f}   return {ep.returns[k]:+.3f}{outcome}"
    )


def _panel(view: ModuleView, ep: Episode | None, notes: list[str]) -> str:
    """Static info panel (HTML) with params, measured clearance and episode summary."""
    rows = [
        f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>" for k, v in view.param_rows()
    ]
    lines = [
        f"<b>module {html.escape(view.id)}</b> · measured clearance "
        f"<b>{view.clearance_m * 1e3:.6f} mm</b> · hole tilt {view.tilt_deg():.2f}°",
    ]
    if ep is not None:
        lines.append(
            f"episode <b>{html.escape(ep.path.name)}</b>: {ep.steps} steps × "
            f"{ep.dt * 1e3:.0f} ms, return {ep.returns[-1]:+.3f}, "
            f"<b>{'success' if ep.success else 'no success'}</b> (timeline below)"
        )
    lines += [f"<b>warning</b>: {html.escape(n)}" for n in notes]
    bottom = "64px" if ep is not None else "8px"
    return (
        f'<div id="assetgen-info" style="position:fixed;left:8px;bottom:{bottom};z-index:10;'
        "max-width:360px;max-height:55vh;overflow:auto;font:12px/1.35 system-ui,sans-serif;"
        'background:rgba(255,255,255,.92);border:1px solid #bbb;border-radius:6px;padding:6px 8px">'
        + "<br>".join(lines)
        + "<details><summary>parameters</summary><table>"
        + "".join(rows)
        + "</table></details><div style='color:#666'>units: metres in the scene; "
        "scene tree (top right) toggles peg, module, collision pieces, frames, section</div>"
        "</div>"
    )


def write_html(
    dataset: str | Path,
    out: str | Path,
    *,
    module: str | None = None,
    episode: str | Path | None = None,
    robot: str | None = None,
) -> Path:
    """Write a self-contained HTML snapshot of one module (default: the episode's module or
    the dataset's first) to `out`; with `episode`, the page replays it; with `robot` (no
    episode), the robot holds the seated peg. Returns the path.

    Raises PreviewError for bad input (no server is left running).
    """
    if robot is not None and episode is not None:
        raise PreviewError(
            "--html --robot shows a module with the robot holding its peg; replay an episode "
            "with the robot in the live viewer (drop --html)"
        )
    ds = open_dataset(dataset)
    ep = load_episode(episode, ds) if episode is not None else None
    if ep is not None:
        if module is not None and normalise_id(ds, module) != ep.module_id:
            raise PreviewError(
                f"--module {module} but the episode ran on module {ep.module_id}; "
                "drop --module or pick that module"
            )
        mid = ep.module_id
    else:
        mid = normalise_id(ds, module) if module is not None else ds.ids[0]
    view = ModuleView(ds, mid)
    notes = [*ep.notes, *fit_notes(ep, view)] if ep is not None else []

    # A throw-away server on loopback: viser serializes what a server's scene holds.
    server = start_server("127.0.0.1", 0)
    try:
        nodes.configure_camera(server)
        handles = nodes.add_module(server.scene, view)
        nodes.add_section(server.scene, view.section(), visible=False)
        if robot is not None:
            from preview.arm import ArmView

            arm = ArmView(ds.module_dir(mid), robot)
            arm_nodes = nodes.add_arm(server.scene, arm)
            nodes.pose_arm(arm_nodes, arm.pose(*view.peg_pose(0.0)))
        if ep is None:
            page = server.scene.as_html()
        else:
            nodes.add_path(server.scene, ep.poses[:, :3])
            label = server.scene.add_label(
                "/episode/status", _status(ep, 0), position=(-0.075, 0.09, 0.01)
            )
            peg = handles["/module/peg"]
            peg.position, peg.wxyz = ep.poses[0, :3], ep.poses[0, 3:]
            recorder = server.get_scene_serializer()
            for k in range(1, ep.steps):
                recorder.insert_sleep(ep.dt)
                peg.position, peg.wxyz = ep.poses[k, :3], ep.poses[k, 3:]
                label.text = _status(ep, k)
            recorder.insert_sleep(ep.dt)
            page = recorder.as_html()
    finally:
        stop_server(server)
    end = page.rindex("</body>")
    page = page[:end] + _panel(view, ep, notes) + page[end:]
    return write_text(out, page)
