"""Browser preview (viser): scene building in metres, frames, lift, section cut, filters and
grid, episode replay, bad input reported with the server still up, loopback-only binding,
the self-contained HTML snapshot and the `view` command wiring. No browser here (see
test_preview_browser.py)."""

from __future__ import annotations

import argparse
import base64
import io
import json
import re
import shutil
import socket
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason="the `view` extra (viser) is not installed")

from rich.console import Console

from assetgen.dataset.generate import generate
from assetgen.dataset.reader import Dataset
from assetgen.dataset.spec import DatasetSpec
from assetgen.params.sampler import SamplerConfig
from preview import command
from preview.episode import fit_notes, load_episode
from preview.scene import (
    ModuleView,
    PreviewError,
    filter_ids,
    grid_positions,
    hole_tilt_deg,
    normalise_id,
    open_dataset,
)
from preview.server import ViewerHandle, exposure_warning, is_loopback, serve
from preview.snapshot import write_html


@pytest.fixture(scope="module")
def preview_dataset(tmp_path_factory) -> Path:
    """Six modules (seeds 0-5) with STL and collision pieces only: what the preview reads
    (independent of the simulation exporters, and quick)."""
    root = tmp_path_factory.mktemp("preview") / "ds"
    spec = DatasetSpec("preview", 0, 6, SamplerConfig(), ("collision",))
    assert not generate(root, spec, workers=1, progress=False).failures
    return root


def _quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


@pytest.fixture
def viewer(preview_dataset):
    h = serve(str(preview_dataset), console=_quiet())
    yield h
    h.stop()


def _trimesh(mesh):
    return mesh.to_trimesh()


def _episode(path: Path, view: ModuleView, steps: int = 30, **over) -> Path:
    """A synthetic episode: the peg going straight down the hole axis from 40 mm up."""
    lifts = np.linspace(0.04, 0.0, steps)
    poses = np.array([np.concatenate(view.peg_pose(float(lift))) for lift in lifts])
    data = {
        "module_id": np.array(view.id),
        "poses": poses.astype(np.float32),
        "reward": -lifts.astype(np.float32),
        "success": np.array(True),
        "dt": np.array(0.02),
    }
    data.update(over)
    np.savez(path, **data)
    return path


# ----------------------------------------------------------------------------- scene data


def test_meshes_are_metres_and_frames_sit_on_the_hole_axis(preview_dataset):
    ds = Dataset(preview_dataset)
    for mid in ds.ids:
        v = ModuleView(ds, mid)
        p = v.params
        lo, hi = v.body.vertices.min(0), v.body.vertices.max(0)
        # The STL is millimetres; shown in metres: the plate spans plate_size, top at z = 0.
        np.testing.assert_allclose(hi[:2] - lo[:2], [p["plate_size"]] * 2, atol=1e-6)
        assert abs(hi[2]) < 1e-6
        peg_z = v.peg.vertices[:, 2]
        assert abs(peg_z.min()) < 1e-6 and abs(peg_z.max() - p["peg_height"]) < 1e-6
        assert v.collision, "collision pieces are shown from the MJCF"
        for piece in v.collision:
            assert (piece.vertices.min(0) >= lo - 1e-6).all()
            assert (piece.vertices.max(0) <= hi + 1e-6).all()
        axis = v.hole_axis
        bottom = np.asarray(v.frames["bottom"].pos)
        entrance = np.asarray(v.frames["entrance"].pos)
        design = np.asarray(v.frames["design_pose"].pos)
        assert abs(entrance[2]) < 1e-9, "entrance frame lies on the top surface"
        d = entrance - bottom
        np.testing.assert_allclose(np.cross(d, axis), 0, atol=1e-7)  # on the axis
        np.testing.assert_allclose(design, bottom + p["clearance"] * axis, atol=1e-9)
        assert abs(v.tilt_deg() - hole_tilt_deg(p)) < 1e-6
        assert 0.9e-3 < v.clearance_m < 1.1e-3


def test_lift_moves_the_peg_along_the_axis_only(preview_dataset):
    v = ModuleView(Dataset(preview_dataset), "000001")
    p0, q0 = v.peg_pose(0.0)
    np.testing.assert_allclose(p0, v.frames["design_pose"].pos)
    p1, q1 = v.peg_pose(0.025)
    np.testing.assert_allclose(p1 - p0, 0.025 * v.hole_axis, atol=1e-12)
    np.testing.assert_allclose(q1, q0)
    assert v.max_lift_m > 0.02


def _point_segment_distance(pts: np.ndarray, segs: np.ndarray) -> np.ndarray:
    a, b = segs[:, 0], segs[:, 1]
    ab = b - a
    t = np.einsum("psk,sk->ps", pts[:, None] - a[None], ab) / np.maximum(
        np.einsum("sk,sk->s", ab, ab), 1e-30
    )
    closest = a[None] + np.clip(t, 0, 1)[..., None] * ab[None]
    return np.linalg.norm(pts[:, None] - closest, axis=2).min(1)


@pytest.mark.parametrize("azimuth", [130.0, 20.0])
def test_section_cut_shows_the_clearance(preview_dataset, azimuth):
    v = ModuleView(Dataset(preview_dataset), "000002")
    sec = v.section(0.0, azimuth)
    n, p = sec.normal, sec.point
    assert abs(n @ v.hole_axis) < 1e-12, "the plane contains the hole axis"
    for half in (sec.body, sec.peg):
        assert len(half.faces) and (((half.vertices - p) @ n) >= -1e-6).all()
        assert _trimesh(half).is_watertight, "cut faces are capped"
    # Both halves of the peg add up to the whole peg.
    other = v.section(0.0, azimuth + 180.0).peg
    peg_world = v.peg.transformed(v.peg_matrix(0.0))
    total = _trimesh(sec.peg).volume + _trimesh(other).volume
    assert total == pytest.approx(_trimesh(peg_world).volume, rel=1e-4)
    # In the plane, the peg's outline keeps the clearance from the hole's (the bottom face
    # faces the floor exactly `clearance` away, and lies in the plane's direction).
    peg_segs = np.asarray(__import__("trimesh").intersections.mesh_plane(_trimesh(peg_world), n, p))
    body_segs = sec.outline[: len(sec.outline) - len(peg_segs)]
    samples = peg_segs[:, :1] + np.linspace(0, 1, 41)[None, :, None] * np.diff(peg_segs, axis=1)
    gap = _point_segment_distance(samples.reshape(-1, 3), body_segs).min()
    assert gap == pytest.approx(v.clearance_m, abs=5e-6)


def test_filters_and_grid_layout(preview_dataset):
    ds = Dataset(preview_dataset)
    counts = {mid: int(r["params"]["n_vertices"]) for mid, r in ds.records.items()}
    some = next(iter(counts.values()))
    assert filter_ids(ds.records, n_vertices=some) == sorted(
        m for m, c in counts.items() if c == some
    )
    tilts = {m: hole_tilt_deg(r["params"]) for m, r in ds.records.items()}
    cut = float(np.median(list(tilts.values())))
    low = filter_ids(ds.records, tilt_deg=(0.0, cut))
    assert low and all(tilts[m] <= cut + 0.01 for m in low)
    assert filter_ids(ds.records) == ds.ids
    g = grid_positions(7, 0.2)
    assert g.shape == (7, 3) and abs(g[:, :2].mean(0)).max() < 0.2
    d = np.linalg.norm(g[:, None] - g[None], axis=2) + np.eye(7)
    assert d.min() == pytest.approx(0.2)


def test_ids_normalised_and_bad_ids_named(preview_dataset):
    ds = Dataset(preview_dataset)
    assert normalise_id(ds, "3") == "000003" == normalise_id(ds, 3)
    with pytest.raises(PreviewError, match=r"'999' is not in .*ids 000000 \.\. 000005"):
        normalise_id(ds, "999")
    with pytest.raises(PreviewError, match="does not exist"):
        open_dataset(preview_dataset.parent / "missing")


# ----------------------------------------------------------------------------- live viewer


def test_viewer_builds_the_module_in_metres(viewer, preview_dataset):
    app = viewer.app
    v = app.view
    assert v is not None and v.id == "000000"
    body = app.nodes["/module/body"]
    np.testing.assert_allclose(body.vertices, v.body.vertices, atol=1e-6)  # metres, as read
    peg = app.nodes["/module/peg"]
    np.testing.assert_allclose(peg.position, v.frames["design_pose"].pos, atol=1e-7)
    for key in ("entrance", "bottom"):
        f = app.nodes[f"/module/{key}"]
        np.testing.assert_allclose(f.position, v.frames[key].pos, atol=1e-7)
        q = np.asarray(v.frames[key].quat)
        assert min(np.abs(f.wxyz - q).max(), np.abs(f.wxyz + q).max()) < 1e-6
    pieces = [n for n in app.nodes if n.startswith("/module/collision/piece_")]
    assert len(pieces) == len(v.collision)
    assert not app.nodes["/module/collision"].visible  # off until toggled
    app.g_show_coll.value = True
    assert app.nodes["/module/collision"].visible
    app.g_show_peg.value = False
    assert not app.nodes["/module/peg"].visible
    assert "clearance" in app.g_info.content and "circumradius" in app.g_params.content


def test_lift_slider_moves_peg_and_section_follows(viewer):
    app = viewer.app
    v = app.view
    app.g_lift.value = 20.0  # mm
    peg = app.nodes["/module/peg"]
    np.testing.assert_allclose(
        peg.position - np.asarray(v.frames["design_pose"].pos), 0.020 * v.hole_axis, atol=1e-6
    )
    app.g_section.value = True
    assert not app.nodes["/module/body"].visible and not app.nodes["/module/peg"].visible
    sec_peg = app.nodes["/section/peg"].vertices
    lifted = v.section(0.020, app.g_cut.value).peg.vertices
    np.testing.assert_allclose(sec_peg.mean(0), lifted.mean(0), atol=1e-6)
    app.g_lift.value = 0.0
    assert app.nodes["/section/peg"].vertices.mean(0)[2] < sec_peg.mean(0)[2]
    app.g_section.value = False
    assert "/section/body" not in app.nodes and app.nodes["/module/body"].visible


def test_module_dropdown_filters_and_grid(viewer, preview_dataset):
    app = viewer.app
    ds = Dataset(preview_dataset)
    app.g_module.value = "000004"
    assert app.view.id == "000004"
    app.browse(+1)
    assert app.view.id == "000005"
    app.browse(+1)
    assert app.view.id == "000000"
    n = str(ds.records["000003"]["params"]["n_vertices"])
    app.g_vertices.value = n
    assert set(app.g_module.options) == set(filter_ids(ds.records, n_vertices=int(n)))
    assert app.view.id in app.g_module.options
    app.g_vertices.value = "any"
    app.g_grid_n.value = 4
    app.g_grid.value = True
    assert app.grid_ids == ds.ids[:4]
    assert not app.nodes["/module"].visible
    origins = np.array([app.nodes[f"/grid/m{m}"].position for m in app.grid_ids])
    assert np.linalg.norm(origins[0] - origins[1]) >= 0.15  # plates do not overlap
    app.g_grid.value = False
    assert app.grid_ids == [] and app.nodes["/module"].visible


def test_episode_replay(viewer, preview_dataset, tmp_path):
    app = viewer.app
    ds = Dataset(preview_dataset)
    v = ModuleView(ds, "000002")
    path = _episode(tmp_path / "ep.npz", v, steps=40)
    assert app.load_episode(path)
    assert app.view.id == "000002" and app.episode is not None
    assert app.g_lift.disabled and not app.g_ep_step.disabled
    app.g_ep_step.value = 10
    ep = app.episode
    np.testing.assert_allclose(app.nodes["/module/peg"].position, ep.poses[10, :3], atol=1e-6)
    assert "reward" in app.g_ep_now.content and "t = **0.20 s**" in app.g_ep_now.content
    app.g_ep_step.value = ep.steps - 1
    assert "success" in app.g_ep_now.content
    app.g_ep_speed.value = "4"
    app.g_ep_step.value = 0
    app.play()
    deadline = time.time() + 5
    while app.g_ep_step.value < 5 and time.time() < deadline:
        time.sleep(0.02)
    app.pause()
    k = app.g_ep_step.value
    assert k >= 5 and not app.playing
    time.sleep(0.1)
    assert app.g_ep_step.value == k, "pause stops the timeline"
    np.testing.assert_allclose(app.nodes["/module/peg"].position, ep.poses[k, :3], atol=1e-6)
    # Another module: the episode waits, the lift slider is back.
    app.g_module.value = "000001"
    assert not app.g_lift.disabled and app.g_ep_step.disabled


def test_bad_input_is_reported_and_the_server_keeps_running(preview_dataset, tmp_path):
    console = _quiet()
    h = serve(str(tmp_path / "nope"), console=console)
    try:
        app = h.app
        assert app.messages[-1][0] == "error" and "does not exist" in app.messages[-1][1]
        assert "does not exist" in console.file.getvalue()  # terminal
        assert "does not exist" in app.g_status.content  # page
        with urllib.request.urlopen(h.url, timeout=10) as r:  # still serving
            assert r.status == 200
        # Recover from the page: open the right dataset.
        assert app.open_dataset(str(preview_dataset)) and app.view.id == "000000"
        assert not app.show_module("42")
        assert "'42' is not in" in app.messages[-1][1] and app.view.id == "000000"

        other = ModuleView(Dataset(preview_dataset), "000001")
        cases = {
            "foreign.npz": (dict(module_id=np.array("123456")), "another dataset"),
            "shape.npz": (dict(poses=np.zeros((5, 3))), r"shape \(5, 3\)"),
            "nan.npz": (dict(reward=np.full(30, np.nan)), "NaN"),
            "far.npz": (dict(poses=np.tile([[5.0, 0, 0, 1, 0, 0, 0]], (30, 1))), "module frame"),
        }
        for name, (over, pattern) in cases.items():
            assert not app.load_episode(_episode(tmp_path / name, other, **over))
            assert re.search(pattern, app.messages[-1][1]), (name, app.messages[-1])
            assert app.episode is None
        (tmp_path / "corrupt.npz").write_bytes(b"PK\x03\x04 not really a zip")
        good = _episode(tmp_path / "good.npz", other)
        with np.load(good) as z:
            np.savez_compressed(tmp_path / "packed.npz", **dict(z))
        raw = bytearray((tmp_path / "packed.npz").read_bytes())
        raw[200:400] = bytes(x ^ 0xFF for x in raw[200:400])  # inside the compressed data
        (tmp_path / "flipped.npz").write_bytes(raw)
        (tmp_path / "truncated.npz").write_bytes(raw[: len(raw) // 2])
        for name in ("corrupt.npz", "flipped.npz", "truncated.npz"):
            assert not app.load_episode(tmp_path / name)
            assert "not a readable .npz episode" in app.messages[-1][1], app.messages[-1]
        np.savez(tmp_path / "keys.npz", poses=np.zeros((3, 7)))
        assert not app.load_episode(tmp_path / "keys.npz")
        assert "missing key(s) ['module_id', 'reward', 'success']" in app.messages[-1][1]
        # A module folder with a file missing: named, with the repair command.
        broken = tmp_path / "broken"
        shutil.copytree(preview_dataset, broken)
        (broken / "modules" / "000004" / "peg.stl").unlink()
        assert app.open_dataset(str(broken)) and not app.show_module("4")
        assert "incomplete or corrupt" in app.messages[-1][1]
        assert "assetgen check" in app.messages[-1][1]
        # A bad --module at start: reported, the first module shown instead.
        h2 = serve(str(preview_dataset), module="999", console=_quiet())
        try:
            assert h2.app.view.id == "000000"
            assert any("'999' is not in" in m for lvl, m in h2.app.messages if lvl == "error")
        finally:
            h2.stop()
        with urllib.request.urlopen(h.url, timeout=10) as r:
            assert r.status == 200
    finally:
        h.stop()


def test_episode_checks_against_the_geometry(preview_dataset, tmp_path):
    ds = Dataset(preview_dataset)
    v1, v2 = ModuleView(ds, "000001"), ModuleView(ds, "000002")
    ep = load_episode(_episode(tmp_path / "a.npz", v1), ds)
    assert fit_notes(ep, v1) == []
    assert "another dataset" in fit_notes(ep, v2)[0]  # same id elsewhere: a warning
    path = _episode(tmp_path / "nodt.npz", v1)
    with np.load(path) as z:
        data = {k: z[k] for k in z.files if k != "dt"}
    np.savez(path, **data, spawn_pose=data["poses"][0])
    ep = load_episode(path, ds)
    assert ep.dt == 0.02 and "no 'dt'" in ep.notes[0] and ep.steps == 31


# ----------------------------------------------------------------------------- binding


def _listening(port: int) -> set[str]:
    """Local addresses of the LISTEN sockets on `port` (Linux /proc/net/tcp{,6})."""
    found = set()
    for table, fam in (("/proc/net/tcp", socket.AF_INET), ("/proc/net/tcp6", socket.AF_INET6)):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            local, state = line.split()[1], line.split()[3]
            addr, p = local.split(":")
            if int(p, 16) != port or state != "0A":  # 0A = LISTEN
                continue
            raw = bytes.fromhex(addr)
            # /proc stores each 32-bit word in host (little-endian) order.
            raw = b"".join(raw[i : i + 4][::-1] for i in range(0, len(raw), 4))
            found.add(socket.inet_ntop(fam, raw))
    return found


def test_listens_on_loopback_only_by_default(viewer: ViewerHandle):
    assert viewer.host == "127.0.0.1" and viewer.url == f"http://127.0.0.1:{viewer.port}"
    if not Path("/proc/net/tcp").exists():
        pytest.skip("no /proc/net/tcp to read the bound address from")
    assert _listening(viewer.port) == {"127.0.0.1"}


def test_unusable_host_is_refused_at_once(preview_dataset):
    t0 = time.perf_counter()
    with pytest.raises(PreviewError, match=r"cannot listen on host '203\.0\.113\.7'"):
        serve(str(preview_dataset), host="203.0.113.7", console=_quiet())  # TEST-NET-3
    assert time.perf_counter() - t0 < 10  # viser alone would retry 1000 ports, forever


def test_exposure_warning_only_off_loopback():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert exposure_warning("127.0.0.1") is None
    assert not is_loopback("0.0.0.0")
    assert "no authentication" in exposure_warning("0.0.0.0")


# ----------------------------------------------------------------------------- snapshot


def _embedded_scene(page: str) -> dict:
    import msgspec
    import zstandard

    b64 = re.search(r'window.__VISER_EMBED_DATA__="([^"]+)"', page).group(1)
    raw = base64.b64decode(b64)
    inner = zstandard.ZstdDecompressor().decompress(
        raw[8:], max_output_size=int.from_bytes(raw[:8], "little")
    )
    n = int.from_bytes(inner[:8], "little")
    return msgspec.msgpack.decode(inner[8 : 8 + n])


def test_html_snapshot_is_self_contained(preview_dataset, tmp_path):
    out = write_html(str(preview_dataset), tmp_path / "snap.html", module="3")
    page = out.read_text()
    assert not re.search(r"""<(script|link|img)[^>]+(src|href)=["']?https?:""", page)
    assert "module 000003" in page and "measured clearance" in page
    scene = _embedded_scene(page)
    names = json.dumps(scene["messages"], default=str)
    for node in ("/module/body", "/module/peg", "/module/entrance", "/module/bottom"):
        assert node in names
    assert "/module/collision/piece_000" in names and "/section/body" in names


def test_html_snapshot_replays_an_episode(preview_dataset, tmp_path):
    v = ModuleView(Dataset(preview_dataset), "000004")
    ep = _episode(tmp_path / "ep.npz", v, steps=25)
    out = write_html(str(preview_dataset), tmp_path / "ep.html", episode=ep)
    scene = _embedded_scene(out.read_text())
    assert scene["durationSeconds"] == pytest.approx(25 * 0.02)
    assert "episode <b>ep.npz</b>" in out.read_text()
    with pytest.raises(PreviewError, match="ran on module 000004"):
        write_html(str(preview_dataset), tmp_path / "x.html", module="1", episode=ep)


def test_view_command(preview_dataset, tmp_path, capsys):
    p = argparse.ArgumentParser()
    command.add_arguments(p)
    args = p.parse_args([str(preview_dataset), "--html", str(tmp_path / "v.html"), "--module", "2"])
    assert args.host == "127.0.0.1" and args.port is None
    assert command.view_main(args) == 0
    assert (tmp_path / "v.html").exists() and "wrote" in capsys.readouterr().out
    bad = p.parse_args([str(tmp_path / "none"), "--html", str(tmp_path / "w.html")])
    assert command.view_main(bad) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "w.html").exists()
