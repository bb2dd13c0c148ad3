"""Browser preview of datasets and recorded episodes (viser; the `view` extra).

    serve(dataset, module=..., episode=..., host="127.0.0.1", port=None,
          policy=None, record=None) -> ViewerHandle
    write_html(dataset, out, module=..., episode=...) -> Path      (self-contained snapshot)
    command.add_parser (add_arguments, view_main)                   (`assetgen view`)

With a policy (`assetgen view DATASET --policy RUN_OR_POLICY_DIR [--record DIR]`) the page
gets a Policy folder: run the trained policy on the shown module in real time (50 Hz
control), pause, one step at a time, or a new random spawn; the true peg is drawn with the
observed (noisy) one as a blue wireframe over it, with time, reward and success. Every
episode is written as an episode .npz (default folder: a new temporary one, printed) that
"Load episode" replays. NaN actions stop the run with a message in the page.

Modules: scene.py (meshes, frames, lift, section cut, filters; no viser), episode.py (episode
files), nodes.py (viser scene nodes), server.py (the viser server and the live GUI, whose
PreviewApp is made of browse.py (dataset, modules, grid, scene updates), player.py (episode
replay) and live_panel.py (the Policy folder)), live.py (a policy stepping the simulator;
imports torch, rl and sim only when a policy is given), snapshot.py (HTML export).
Names are imported lazily so that `assetgen` commands other than `view` never import viser.
"""

from __future__ import annotations

from typing import Any

__all__ = ["PreviewError", "ViewerHandle", "serve", "write_html"]


def __getattr__(name: str) -> Any:
    if name in ("serve", "ViewerHandle"):
        from preview import server

        return getattr(server, name)
    if name == "write_html":
        from preview.snapshot import write_html

        return write_html
    if name == "PreviewError":
        from preview.scene import PreviewError

        return PreviewError
    raise AttributeError(name)
