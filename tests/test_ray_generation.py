"""`assetgen sample --ray`: a local Ray cluster (loopback, 2 CPUs) writes the same bytes as
the process pool, survives a worker dying mid-module and a killed driver, and an unreachable
address is refused at once with nothing written."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("ray")

ROOT = Path(__file__).resolve().parent.parent
SEEDS = (0, 4)  # start, count


def _sample(out: Path, *extra: str, env: dict | None = None, **kw) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "cli", "sample", "--n", str(SEEDS[1]), "--seed", str(SEEDS[0]),
           "--out", str(out), "--quiet", *extra]  # fmt: skip
    return subprocess.Popen(
        cmd,
        cwd=ROOT,
        env={**os.environ, "RAY_USAGE_STATS_ENABLED": "0", **(env or {})},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # the driver and the Ray instance it starts: one group to kill
        **kw,
    )


def _finish(p: subprocess.Popen, timeout: float = 300) -> tuple[int, str, str]:
    out, err = p.communicate(timeout=timeout)
    return p.returncode, out, err


def _hash(root: Path) -> str:
    return json.loads((root / "dataset.json").read_text())["summary"]["content_hash"]


@pytest.fixture(scope="module")
def pool_hash(tmp_path_factory) -> str:
    root = tmp_path_factory.mktemp("pool") / "d"
    rc, out, err = _finish(_sample(root, "--workers", "1"))
    assert rc == 0, out + err
    return _hash(root)


def test_unreachable_address_is_refused_fast_and_writes_nothing(tmp_path) -> None:
    out = tmp_path / "d"
    t0 = time.perf_counter()
    rc, _, err = _finish(_sample(out, "--ray", "127.0.0.1:9"), timeout=60)
    assert rc == 2 and "no Ray cluster answers" in err and "Traceback" not in err
    assert time.perf_counter() - t0 < 15  # seconds, including the interpreter's start
    assert not out.exists()


def test_a_server_that_is_not_ray_is_refused(tmp_path) -> None:
    """Something accepts the connection but does not speak Ray's protocol: refused after
    the probe's few seconds, not after Ray's minute of retries."""
    import socket
    import threading

    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]
    held = []
    threading.Thread(
        target=lambda: [held.append(server.accept()) for _ in range(4)], daemon=True
    ).start()
    out = tmp_path / "d"
    t0 = time.perf_counter()
    try:
        rc, _, err = _finish(_sample(out, "--ray", f"127.0.0.1:{port}"), timeout=60)
    finally:
        server.close()
    assert rc == 2 and "not a Ray head" in err, err
    assert time.perf_counter() - t0 < 20
    assert not out.exists()


def test_worker_killed_mid_module_is_retried(tmp_path, pool_hash) -> None:
    """The worker that starts module 2 dies once, leaving a half-written temporary folder:
    Ray runs the module again and the dataset is the pool's, byte for byte."""
    out = tmp_path / "d"
    marker = tmp_path / "crashed"
    env = {"ASSETGEN_CRASH_ONCE": f"2:{marker}"}
    rc, o, err = _finish(_sample(out, "--ray", "--workers", "2", env=env))
    assert rc == 0, o + err
    assert marker.exists(), "the fault was never injected"
    assert _hash(out) == pool_hash
    assert sorted(p.name for p in (out / "modules").iterdir()) == [
        f"{s:06d}" for s in range(SEEDS[0], SEEDS[0] + SEEDS[1])
    ]  # no temporary folder left


def test_killed_driver_resumes_to_the_same_hash(tmp_path, pool_hash) -> None:
    out = tmp_path / "d"
    p = _sample(out, "--ray", "--workers", "2")
    deadline = time.time() + 240
    modules = out / "modules"
    while time.time() < deadline and p.poll() is None:
        if modules.exists() and any(d.name[0].isdigit() for d in modules.iterdir()):
            break
        time.sleep(0.2)
    killed = p.poll() is None
    if killed:
        os.killpg(p.pid, signal.SIGKILL)  # the driver and the local Ray instance with it
    p.communicate()
    assert killed, "the run finished before it could be killed"
    rc, o, err = _finish(_sample(out, "--ray", "--workers", "2"))
    assert rc == 0, o + err
    assert _hash(out) == pool_hash
    assert not list(modules.glob(".tmp-*"))


def test_joining_a_cluster_started_with_token_authentication(tmp_path, pool_hash) -> None:
    """`ray start --head` (token authentication on, as Ray turns it on from 2.59): a driver
    without the cluster's token is refused at once, naming what to do; with the token where
    Ray keeps it, the same bytes as the process pool."""
    import shutil
    import socket

    if any(k in os.environ for k in ("RAY_AUTH_MODE", "RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH")):
        pytest.skip("the environment sets Ray's authentication already")
    ray_cli = shutil.which("ray") or str(Path(sys.executable).with_name("ray"))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_USAGE_STATS_ENABLED": "0"}
    subprocess.run([ray_cli, "start", "--head", "--node-ip-address", "127.0.0.1", "--port",
                    str(port), "--num-cpus", "1", "--include-dashboard", "false",
                    "--disable-usage-stats"], env=env, check=True, capture_output=True,
                   timeout=120)  # fmt: skip
    try:
        home = tmp_path / "home"  # no ~/.ray/auth_token there
        home.mkdir()
        out = tmp_path / "refused"
        t0 = time.perf_counter()
        rc, _, err = _finish(_sample(out, "--ray", f"127.0.0.1:{port}", env={"HOME": str(home)}),
                             timeout=60)  # fmt: skip
        assert rc == 2 and "uses token authentication" in err and "Traceback" not in err, err
        assert time.perf_counter() - t0 < 20 and not out.exists()
        joined = tmp_path / "joined"
        rc, text, err = _finish(_sample(joined, "--ray", f"127.0.0.1:{port}"), timeout=600)
        assert rc == 0, text + err
        assert _hash(joined) == pool_hash
    finally:
        subprocess.run([ray_cli, "stop", "--force"], capture_output=True, timeout=120)
