"""Join or start a Ray cluster for one command, and check before any work that it can do that work.

    with connect(parse_cluster("local")) as conn:        # or "auto", "ray://head:10001"
        require_cpus(conn, 2, "--replicas 2")
        ...                                              # runner.run_units(..., connection=conn)

Every way this can go wrong is one ClusterError line, never a hang and never a traceback:
- the address does not answer (checked with a plain TCP connection first, `REACH_TIMEOUT_S`), or Ray refuses it;
- `auto` without a cluster started on this machine;
- Ray or Python versions differ between this machine and the cluster (Ray refuses; the line says which versions);
- the cluster's workers cannot import gesturelsm, or run other code or checkpoints than this machine: a probe task on
  every node with CPUs compares `package_fingerprint()` (a hash of the package's Python files and the shipped
  checkpoints), so a result never silently comes from different code;
- too few CPUs for what was asked (`require_cpus`).

Ray is imported here inside the functions only: a command without --cluster never loads it.
"""
from __future__ import annotations

import hashlib
import logging
import os
import re
import socket
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from ..constants import ASSETS
from ..errors import ClusterError
from .address import ClusterAddress

REACH_TIMEOUT_S = 5.0           # a TCP connection to the address
PROBE_TIMEOUT_S = 180.0         # the package check on every node (a fresh worker imports the package first)
LOCAL_OBJECT_STORE_MB = 512     # `--cluster local`: results (videos, motions) pass through it, a few MB each
PACKAGE = Path(__file__).resolve().parents[1]


@lru_cache(maxsize=1)
def package_fingerprint() -> str:
    """12 hex digits over the package's Python files and the shipped checkpoints and body model: equal on two machines
    when they run the same code on the same models."""
    h = hashlib.sha256()
    for tag, root, files in (("package", PACKAGE, PACKAGE.rglob("*.py")),
                             ("assets", ASSETS,
                              (p for p in ASSETS.rglob("*") if p.suffix in (".safetensors", ".npz")))):
        for p in sorted(files):
            h.update(f"{tag}/{p.relative_to(root).as_posix()}\0".encode())
            h.update(p.read_bytes())
    return h.hexdigest()[:12]


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("gesturelsm")
    except PackageNotFoundError:
        return "unknown"


@dataclass
class Connection:
    """This process's connection to a cluster (Ray's is process-wide); `close()` disconnects, and stops the cluster
    when this process started it (`--cluster local`)."""
    address: ClusterAddress
    cpus: float                  # CPUs of all nodes together
    nodes: int                   # alive nodes
    owned: bool                  # started by this process

    def close(self) -> None:
        import ray

        if ray.is_initialized():
            ray.shutdown()

    def __enter__(self) -> "Connection":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def describe(self) -> str:
        where = "on this machine" if self.owned else f"at {self.address}"
        return f"Ray cluster {where}: {self.nodes} node(s), {self.cpus:g} CPU(s)"


def connect(address: ClusterAddress, num_cpus: int | None = None, check_package: bool = True,
            module: str = "gesturelsm", fingerprint: str | None = None,
            probe_timeout: float = PROBE_TIMEOUT_S) -> Connection:
    """Start (`local`, with `num_cpus` or all cores) or join (`auto`, `ray://`) a cluster, then check that every
    node with CPUs imports `module` and runs the same code as this machine (`fingerprint`, default
    `package_fingerprint()`). Any problem is a ClusterError, after which nothing of Ray is left running."""
    import ray

    if ray.is_initialized():
        ray.shutdown()
    check_reachable(address)
    _init(address, num_cpus)
    try:
        nodes = [n for n in ray.nodes() if n.get("Alive")]
        cpus = float(sum(n.get("Resources", {}).get("CPU", 0.0) for n in nodes))
        if check_package:
            check_workers(nodes, module, fingerprint or package_fingerprint(), probe_timeout)
    except BaseException:
        ray.shutdown()
        raise
    return Connection(address, cpus, len(nodes), address.kind == "local")


def check_reachable(address: ClusterAddress | None) -> None:
    """The cluster `address` names answers a plain TCP connection (at most REACH_TIMEOUT_S; `local` is started,
    nothing to reach): what `connect` checks first. The commands that load models before they connect (batch,
    sweep, eval, genea submit) call it with their arguments' checks, so that an unreachable cluster or `auto` without
    one is one line before any work, not after the models have loaded. ClusterError otherwise."""
    if address is None or address.kind == "local":
        return
    if address.kind == "client":
        _reachable(address.host, address.port, str(address))
    else:
        host, port = _local_head()
        _reachable(host, port, f"{host}:{port}, the one recorded on this machine (or in RAY_ADDRESS),")


def require_cpus(conn: Connection, needed: float, what: str) -> None:
    """A ClusterError when the cluster has fewer CPUs than `what` needs (Ray would wait for them forever)."""
    if conn.cpus < needed:
        raise ClusterError(f"{what} needs {needed:g} CPU(s) but the {conn.describe()} has {conn.cpus:g}: "
                           "ask for less, or add nodes (`ray start --address=HEAD:6379` on another machine)")


def _reachable(host: str, port: int, shown: str) -> None:
    try:
        with socket.create_connection((host, port), timeout=REACH_TIMEOUT_S):
            return
    except OSError as exc:
        reason = "no answer" if isinstance(exc, socket.timeout) else (exc.strerror or str(exc)).lower()
        raise ClusterError(f"cannot reach the Ray cluster at {shown} ({reason}): start it with `ray start --head` "
                           "there, or check the address and the firewall") from None


def _local_head() -> tuple[str, int]:
    """(host, port) of the cluster `--cluster auto` joins: RAY_ADDRESS, else the one `ray start` recorded here."""
    from ray._private.services import canonicalize_bootstrap_address_or_die

    try:
        address = canonicalize_bootstrap_address_or_die("auto")
    except (ConnectionError, ValueError):
        raise ClusterError("--cluster auto: no Ray cluster runs on this machine (start one with `ray start --head`, "
                           "or set RAY_ADDRESS), or use --cluster local to start one for this command") from None
    host, _, port = address.rpartition(":")
    return host.strip("[]"), int(port)


def _init(address: ClusterAddress, num_cpus: int | None) -> None:
    """ray.init in this thread (Ray's start-up hangs in any other); the TCP check before it and Ray's own connection
    timeouts bound the wait."""
    import ray

    kwargs = dict(logging_level=logging.ERROR, log_to_driver=False)
    if address.kind == "local":
        kwargs.update(num_cpus=num_cpus or os.cpu_count(), include_dashboard=False,
                      object_store_memory=LOCAL_OBJECT_STORE_MB * 2 ** 20)
    try:
        ray.init(address=address.ray_address, **kwargs)
    except Exception as exc:
        ray.shutdown()                            # a half-made connection too
        raise _connect_error(address, exc) from None


def _connect_error(address: ClusterAddress, exc: BaseException) -> ClusterError:
    text = str(exc)
    versions = re.findall(r"Ray: (\S+)\s+Python: (\S+)", text)
    if "Version mismatch" in text and len(versions) == 2:
        (ray_c, py_c), (ray_m, py_m) = versions
        return ClusterError(f"version mismatch: the cluster at {address} runs Ray {ray_c} on Python {py_c}, this "
                            f"machine Ray {ray_m} on Python {py_m}; install the same on every machine "
                            "(requirements.txt pins ray)")
    if type(exc).__name__ == "AuthenticationError" or "token" in text.lower() and "auth" in text.lower():
        return ClusterError(f"the cluster at {address} refused this machine's Ray token: copy ~/.ray/auth_token "
                            "from its head here, or set RAY_AUTH_TOKEN")
    first = text.strip().splitlines()[0] if text.strip() else type(exc).__name__
    return ClusterError(f"cannot connect to the Ray cluster at {address}: {first}")


def _probe_function():
    """The task run on every node: it must run where gesturelsm is missing, so it is built here (cloudpickle sends a
    nested function by value) and imports the package itself."""
    def probe(module: str) -> dict:
        import importlib
        import platform

        out = {"python": platform.python_version(), "executable": sys.executable, "host": platform.node()}
        try:
            importlib.import_module(module)
            found = importlib.import_module(f"{module}.cluster.connect")
        except ImportError as exc:
            return {**out, "error": f"{type(exc).__name__}: {exc}"}
        return {**out, "version": found.package_version(), "fingerprint": found.package_fingerprint()}
    return probe


def check_workers(nodes: list[dict], module: str, fingerprint: str, timeout: float) -> list[dict]:
    """Run the probe once on every node with CPUs; ClusterError for a node that cannot import `module` or runs other
    code than `fingerprint`. Returns the probes' answers."""
    import ray
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    workers = [n for n in nodes if n.get("Resources", {}).get("CPU", 0) > 0]
    if not workers:
        raise ClusterError("the Ray cluster has no node with CPUs to run work on")
    probe = ray.remote(num_cpus=0, max_retries=1)(_probe_function())
    refs = [probe.options(scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False))
            .remote(module) for n in workers]
    ready, pending = ray.wait(refs, num_returns=len(refs), timeout=timeout)
    if pending:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise ClusterError(f"{len(pending)} of {len(refs)} node(s) did not run a check task within {timeout:.0f} s; "
                           "see `ray status` on the head")
    answers = ray.get(refs)
    for node, got in zip(workers, answers):
        where = f"node {node.get('NodeManagerAddress', '?')} ({got['executable']})"
        if "error" in got:
            raise ClusterError(f"the cluster's workers cannot import {module} on {where}: install this package in "
                               f"the Python environment Ray runs there ({got['error']})")
        if got["fingerprint"] != fingerprint:
            raise ClusterError(f"{where} runs other code or checkpoints (gesturelsm {got['version']}, fingerprint "
                               f"{got['fingerprint']}) than this machine ({package_version()}, {fingerprint}): "
                               "install the same checkout or wheel on every node")
    return answers


__all__ = ["Connection", "LOCAL_OBJECT_STORE_MB", "check_workers", "connect", "package_fingerprint",
           "package_version", "require_cpus"]
