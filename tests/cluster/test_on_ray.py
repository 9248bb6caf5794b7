"""The cluster package on a real multi-node Ray cluster simulated on this machine: joining it, its checks (the
package missing on workers, other code, other versions, too few CPUs), and the runner's tasks: spread over the nodes,
failures listed, and a node removed mid-run without losing or repeating a unit."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from gesturelsm.cluster import Job, Unit, connect, parse_cluster, require_cpus, run_units
from gesturelsm.cluster.connect import check_workers, package_fingerprint
from gesturelsm.errors import ClusterError

import _cluster_support as units
from _support import until

AUTO = parse_cluster("auto")


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


def _ray_is_down() -> bool:
    import ray

    return not ray.is_initialized()


def test_join_run_units_on_both_nodes_and_list_failures(ray_cluster):
    written = {}
    with connect(AUTO) as conn:
        assert (conn.nodes, conn.cpus, conn.owned) == (2, 2.0, False)
        assert conn.describe() == "Ray cluster at auto: 2 node(s), 2 CPU(s)"
        todo = [Unit(f"u{i}", ("sleep", 0.5, i), label=f"item {i}") for i in range(8)]
        report = run_units(Job(units.work, units.build, 10), todo, lambda u, r: written.__setitem__(u.key, r),
                           connection=conn)
    assert _ray_is_down()
    assert {k: v[0] for k, v in written.items()} == {f"u{i}": 10 + i for i in (0, 1, 2, 5, 6, 7)}
    assert len({pid for _, pid in written.values()}) == 2 and os.getpid() not in {p for _, p in written.values()}
    assert [str(f) for f in report.failed] == ["u3 (item 3): three is not accepted", "u4 (item 4): KeyError: 'four'"]


def test_a_node_removed_mid_run_still_yields_every_unit_exactly_once(ray_cluster, tmp_path):
    """The first unit is short: after its result arrives and both nodes are inside a long one, the worker node is
    removed; its unit dies with it, runs again on the node left, and is written once."""
    worker_node = next(iter(ray_cluster.worker_nodes))
    calls: list[str] = []
    pids: list[int] = []

    def write(unit, result):
        calls.append(unit.key)
        pids.append(result[1])
        if len(calls) == 1:                       # once both nodes are inside a long unit, take one node away
            until(lambda: sum(line.split()[0] != "10" for line in _lines(starts)) >= 2,
                  "both nodes were running a long unit", limit=600)
            ray_cluster.remove_node(worker_node, allow_graceful=False)

    try:
        with connect(AUTO) as conn:
            starts = tmp_path / "starts.txt"
            todo = [Unit(f"u{i}", ("sleep", 0.5 if i == 0 else 3.0, 10 + i, str(starts))) for i in range(5)]
            report = run_units(Job(units.work, units.build, 0), todo, write, connection=conn)
    finally:
        ray_cluster.add_node(**units.NODE)
        ray_cluster.wait_for_nodes()
    assert sorted(calls) == sorted(f"u{i}" for i in range(5)) and len(calls) == 5
    started = starts.read_text().split()[::2]
    assert len(started) == 6 and len(set(started)) == 5       # one unit started twice (its node died), written once
    assert len(set(pids[1:])) == 1                              # after the removal, the node left did the rest
    assert report.failed == [] and sorted(report.done) == sorted(calls)


def test_a_worker_killed_mid_unit_runs_it_again_and_writes_it_once(ray_cluster, tmp_path):
    """A worker process killed (SIGKILL: out of memory, a person's kill) while a unit runs on it: Ray runs the unit
    again in a new worker, the command writes it once, and every other unit once; nothing is listed as failed."""
    import signal
    import threading
    import time

    starts = tmp_path / "starts.txt"
    starts.touch()
    killed: list[int] = []

    def kill_the_worker_of_unit_2() -> None:
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline:
            for line in starts.read_text().splitlines():
                x, pid = line.split()
                if x == "12":
                    os.kill(int(pid), signal.SIGKILL)
                    killed.append(int(pid))
                    return
            time.sleep(0.02)

    calls: list[str] = []
    killer = threading.Thread(target=kill_the_worker_of_unit_2, daemon=True)
    killer.start()
    with connect(AUTO) as conn:
        todo = [Unit(f"u{i}", ("sleep", 3.0 if i == 2 else 0.3, 10 + i, str(starts))) for i in range(4)]
        report = run_units(Job(units.work, units.build, 0), todo, lambda u, r: calls.append(u.key), connection=conn)
    killer.join(10)
    assert killed, "unit 2 never started"
    assert sorted(calls) == ["u0", "u1", "u2", "u3"]                   # each written once
    started = [line.split() for line in starts.read_text().splitlines()]
    again = [pid for x, pid in started if x == "12"]
    assert len(again) == 2 and int(again[0]) == killed[0] and int(again[1]) != killed[0]   # run again, elsewhere
    assert sorted(x for x, _ in started if x != "12") == ["10", "11", "13"]
    assert report.failed == [] and sorted(report.done) == sorted(calls)


def test_workers_without_the_package_or_with_other_code_are_refused(ray_cluster):
    import ray

    with connect(AUTO, check_package=False):
        nodes = [n for n in ray.nodes() if n["Alive"]]
        with pytest.raises(ClusterError) as err:
            check_workers(nodes, "gesturelsm_not_installed", package_fingerprint(), 120)
        assert "the cluster's workers cannot import gesturelsm_not_installed on node" in str(err.value)
        assert "install this package in the Python environment Ray runs there" in str(err.value)
        with pytest.raises(ClusterError) as err:
            check_workers(nodes, "gesturelsm", "000000000000", 120)
        assert f"fingerprint {package_fingerprint()}) than this machine" in str(err.value)
        assert "install the same checkout or wheel on every node" in str(err.value)
        assert len(check_workers(nodes, "gesturelsm", package_fingerprint(), 120)) == 2
    with pytest.raises(ClusterError, match="runs other code or checkpoints"):
        connect(AUTO, fingerprint="000000000000")
    assert _ray_is_down()                         # a refused cluster leaves nothing connected


def test_too_few_cpus_and_other_versions_are_one_line(ray_cluster, monkeypatch):
    with connect(AUTO, check_package=False) as conn:
        with pytest.raises(ClusterError) as err:
            require_cpus(conn, 3, "--replicas 3")
        require_cpus(conn, 2, "--replicas 2")
    assert str(err.value) == ("--replicas 3 needs 3 CPU(s) but the Ray cluster at auto: 2 node(s), 2 CPU(s) has 2: "
                              "ask for less, or add nodes (`ray start --address=HEAD:6379` on another machine)")
    import ray._private.utils

    monkeypatch.setattr(ray._private.utils, "compute_version_info", lambda: ("2.0.0", "3.9.1"))
    with pytest.raises(ClusterError) as err:
        connect(AUTO)
    import ray
    assert str(err.value).startswith(f"version mismatch: the cluster at auto runs Ray {ray.__version__} on Python ")
    assert "this machine Ray 2.0.0 on Python 3.9.1; install the same on every machine" in str(err.value)
    assert _ray_is_down()
