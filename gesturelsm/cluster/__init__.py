"""Past one machine: the work of `gesturelsm batch`, `sweep` and `eval` as Ray tasks, one per unit (a video, a sweep
cell, an evaluation clip), and the checks that make a cluster usable (docs/CLUSTER.md).

    from gesturelsm.cluster import Job, Unit, connect, parse_cluster, run_units
    with connect(parse_cluster("local")) as conn:
        report = run_units(Job(work, build, spec), units, on_result=write, connection=conn)

address.py  the `--cluster local|auto|ray://HOST:PORT` value      connect.py  join or start a cluster, check it
runner.py   units here or as tasks: retries, failures, progress    files.py    files that travel, atomic writes
progress.py the progress line with the time left

Nothing here imports Ray until a cluster is asked for: without --cluster the same units run in this process.
"""
from __future__ import annotations

from .address import (ClusterAddress, ReplicaCount, add_cluster_argument, cluster_argument, parse_cluster,
                      parse_replicas, replicas_argument)
from .connect import Connection, check_reachable, connect, package_fingerprint, require_cpus
from .files import Files, write_atomic
from .progress import ProgressLine, Tally
from .runner import Failure, Job, RunReport, Stopped, Unit, run_units

__all__ = ["ClusterAddress", "Connection", "Failure", "Files", "Job", "ProgressLine", "ReplicaCount", "RunReport",
           "Stopped", "Tally", "Unit", "add_cluster_argument", "check_reachable", "cluster_argument", "connect",
           "package_fingerprint", "parse_cluster", "parse_replicas", "replicas_argument", "require_cpus", "run_units",
           "write_atomic"]
