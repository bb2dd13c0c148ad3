"""Modules as Ray tasks: `assetgen sample ... --ray [ADDRESS]`, for datasets larger than one
machine.

Each module is one task running the same function as the local process pool
(assetgen.dataset.generate._worker), so the bytes and the content hash are the same. The
driver keeps the manifest, as with the pool; a task writes its module into the dataset folder,
which every node must see (a shared file system), through the same temporary folder and
atomic rename. So:
- a killed driver leaves finished modules, and the same command resumes;
- a worker killed mid-module leaves only a temporary folder (removed at the end of the run);
  Ray runs the task again (RETRIES times), and a module whose worker keeps dying is reported
  as failed by its seed, like a module that fails a check.

Ray is the optional extra `[cluster]`, imported only here.
"""

from __future__ import annotations

import importlib.util
import os
import socket
from collections.abc import Iterable, Iterator
from urllib.parse import urlparse

from assetgen.dataset.spec import DatasetError

RETRIES = 2
"""Times Ray re-runs a module whose worker died, before it is reported as failed."""
CONNECT_TIMEOUT_S = 3.0
"""How long the address may take to accept a TCP connection, and then to answer the GCS
ping, before the run is refused."""
IN_FLIGHT_PER_CPU = 4
"""Tasks submitted ahead per cluster CPU: enough to keep every worker busy, few enough that a
100,000-module run does not hold 100,000 task records in the driver."""


def import_ray():
    try:
        import ray
    except ImportError:
        raise DatasetError(
            "--ray needs Ray: pip install -c constraints.txt -e '.[cluster]'"
        ) from None
    return ray


GCS_PING = "/ray.rpc.NodeInfoGcsService/GetClusterId"
"""A Ray head's GCS answers this gRPC method (empty request) at once; anything else that
accepts the connection (another service, a proxy) does not."""


def _gcs_answers():
    import grpc

    c = grpc.StatusCode
    return {c.UNAUTHENTICATED, c.PERMISSION_DENIED, c.INVALID_ARGUMENT, c.FAILED_PRECONDITION}


def probe(address: str) -> None:
    """Refuse, within about CONNECT_TIMEOUT_S, an address where no Ray cluster answers (Ray
    itself would retry for a minute or more). HOST:PORT must answer as a Ray head's GCS;
    ray://HOST:PORT (Ray Client) must accept a connection. `auto` is left to Ray."""
    if address == "auto":
        return
    url = urlparse(address if "://" in address else f"tcp://{address}")
    try:
        host, port = url.hostname, url.port
    except ValueError:
        host, port = None, None
    if not host or not port or url.scheme not in ("tcp", "ray"):
        raise DatasetError(
            f"--ray {address!r}: expected HOST:PORT (the head node's GCS, e.g. 10.0.0.5:6379), "
            "ray://HOST:PORT, or auto"
        )
    answer = "open"
    try:
        with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S):
            pass
        if url.scheme == "tcp":
            answer = _ping_gcs(f"{host}:{port}")
    except (OSError, RuntimeError) as e:
        reason = getattr(e, "strerror", None) or str(e)
        raise DatasetError(
            f"--ray {address}: no Ray cluster answers there ({reason}); start one with "
            "`ray start --head` on the head node, or leave out the address for a local Ray "
            "instance. Nothing was written."
        ) from None
    if answer == "token":
        _use_token(address)


def _use_token(address: str) -> None:
    """The head at `address` wants Ray's token authentication (`ray start --head` turns it on
    from Ray 2.59): the driver must run in token mode with the cluster's token. Ray reads the
    token from RAY_AUTH_TOKEN, the file RAY_AUTH_TOKEN_PATH names, or ~/.ray/auth_token;
    where one is there, token mode is switched on for this process, else DatasetError."""
    if os.environ.get("RAY_AUTH_MODE") == "token":
        return  # the user's own setting: Ray reports a wrong token itself
    path = os.environ.get("RAY_AUTH_TOKEN_PATH") or os.path.expanduser("~/.ray/auth_token")
    if not (os.environ.get("RAY_AUTH_TOKEN") or os.path.isfile(path)):
        raise DatasetError(
            f"--ray {address}: the Ray cluster there uses token authentication, and this "
            "machine has no token: copy the head node's ~/.ray/auth_token here (`ray "
            "get-auth-token` on the head prints it) or set RAY_AUTH_TOKEN. Nothing was "
            "written."
        )
    os.environ["RAY_AUTH_MODE"] = "token"


def _ping_gcs(target: str) -> str:
    """ "open" when a Ray head's GCS answers at `target`, "token" when it answers that it
    wants an authentication token; RuntimeError when what answers is not a Ray head."""
    import grpc  # a dependency of Ray

    answers = _gcs_answers()
    with grpc.insecure_channel(target) as channel:
        call = channel.unary_unary(
            GCS_PING, request_serializer=lambda _: b"", response_deserializer=lambda b: b
        )
        try:
            call(None, timeout=CONNECT_TIMEOUT_S)
        except grpc.RpcError as e:
            # A GCS that serves the method but wants the cluster's credentials or id first
            # (Ray 2.5x answers UNAUTHENTICATED) is a Ray head; a server without the method
            # (UNIMPLEMENTED), or without gRPC (UNAVAILABLE, DEADLINE_EXCEEDED), is not.
            if e.code() not in answers:
                raise RuntimeError(f"not a Ray head: {e.code().name}") from None
            if e.code() == grpc.StatusCode.UNAUTHENTICATED and "AuthToken" in (e.details() or ""):
                return "token"
    return "open"


def connect(address: str | None, workers: int | None):
    """Connect to the cluster at `address`, or start a local instance with `workers` CPUs
    (default: all). Returns the ray module."""
    if importlib.util.find_spec("ray") is None:
        import_ray()  # the message naming the extra
    if address:
        probe(address)  # before Ray is imported: it reads RAY_AUTH_MODE then
    ray = import_ray()
    kwargs = {"include_dashboard": False, "log_to_driver": False, "configure_logging": False}
    try:
        if address:
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=workers or os.cpu_count() or 1, **kwargs)
    except (ConnectionError, RuntimeError, ValueError) as e:
        raise DatasetError(f"--ray {address or '(local)'}: Ray did not start: {e}") from None
    return ray


def run_tasks(ray, worker, jobs: Iterable[tuple]) -> Iterator[tuple]:
    """Run `worker(job)` for every job as Ray tasks and yield its results as they finish
    (any order). A job whose worker died RETRIES + 1 times yields (seed, None, reason, {});
    an error raised in the worker (a full disk) is raised here as itself."""
    remote = ray.remote(num_cpus=1, max_retries=RETRIES, retry_exceptions=False)(worker)
    window = max(1, IN_FLIGHT_PER_CPU * int(ray.cluster_resources().get("CPU", 1)))
    todo = iter(jobs)
    seed_of: dict = {}

    def submit(n: int) -> None:
        for job in todo:
            seed_of[remote.remote(job)] = job[0]
            n -= 1
            if n == 0:
                return

    submit(window)
    while seed_of:
        done, _ = ray.wait(list(seed_of), num_returns=1)
        for ref in done:
            seed = seed_of.pop(ref)
            try:
                yield ray.get(ref)
            except ray.exceptions.RayTaskError as e:
                # the worker raised: re-raise the cause (OSError for a full disk) unwrapped
                raise e.cause if isinstance(e.cause, BaseException) else e from None
            except (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError) as e:
                reason = f"its worker died {RETRIES + 1} times ({type(e).__name__})"
                yield seed, None, reason, {}
        submit(len(done))
