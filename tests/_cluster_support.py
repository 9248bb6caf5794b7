"""Unit functions and a simulated multi-node Ray cluster for the cluster tests (workers import this module: the
cluster's processes get tests/ on their PYTHONPATH)."""
from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path
from typing import Iterator

from gesturelsm.errors import InputError

TESTS = Path(__file__).resolve().parent
NODE = dict(num_cpus=1, object_store_memory=100 * 2 ** 20)     # each simulated node: one CPU, a small object store


def build(spec):
    return {"base": spec, "pid": os.getpid()}


def work(built, x):
    """x + base, and the worker's pid; 3 raises a person's error, 4 a bug. ('sleep', s, x[, log]) sleeps s seconds
    first, after appending "x pid" to the file `log` (every start of the unit, retries included)."""
    if isinstance(x, tuple):
        if len(x) > 3:
            with open(x[3], "a") as fh:
                fh.write(f"{x[2]} {os.getpid()}\n")
        time.sleep(x[1])
        x = x[2]
    if x == 3:
        raise InputError("three is not accepted")
    if x == 4:
        raise KeyError("four")
    return built["base"] + x, built["pid"]


@contextlib.contextmanager
def ray_cluster(nodes: int = 2) -> Iterator:
    """`nodes` Ray nodes of one CPU each on this machine (ray.cluster_utils.Cluster), without dashboards; RAY_ADDRESS
    points at it, so `--cluster auto` joins it. Everything is stopped on exit."""
    from ray.cluster_utils import Cluster

    saved = {k: os.environ.get(k) for k in ("RAY_ADDRESS", "PYTHONPATH")}
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(TESTS), saved["PYTHONPATH"]) if p)
    cluster = Cluster(initialize_head=True, head_node_args=dict(NODE, include_dashboard=False))
    try:
        for _ in range(nodes - 1):
            cluster.add_node(**NODE)
        cluster.wait_for_nodes()
        os.environ["RAY_ADDRESS"] = cluster.address
        yield cluster
    finally:
        import ray

        if ray.is_initialized():
            ray.shutdown()
        cluster.shutdown()
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
