"""The cluster package without a cluster: the --cluster value, files that travel, atomic writes, progress with the time
left, and the runner in this process (the path every command takes without --cluster)."""
from __future__ import annotations

import argparse
import io
import os
import sys

import pytest

from gesturelsm.cluster import (ClusterAddress, Files, Job, ProgressLine, Stopped, Tally, Unit, add_cluster_argument,
                                parse_cluster, run_units, write_atomic)
from gesturelsm.cluster.progress import duration
from gesturelsm.errors import ClusterError

import _cluster_support as units


@pytest.mark.parametrize("text, kind, host, port", [
    ("local", "local", None, None), ("AUTO", "auto", None, None), (" auto ", "auto", None, None),
    ("ray://head:10001", "client", "head", 10001), ("ray://10.0.0.5", "client", "10.0.0.5", 10001),
    ("ray://[::1]:2345/", "client", "::1", 2345),
    ("ray://lab-gpu.example.org:443", "client", "lab-gpu.example.org", 443)])
def test_cluster_values(text, kind, host, port):
    a = parse_cluster(text)
    assert (a.kind, a.host, a.port) == (kind, host, port)
    assert a.ray_address == (kind if kind != "client" else f"ray://{host}:{port}")


@pytest.mark.parametrize("text, says", [
    ("", "must be local, auto or ray://HOST:PORT"), ("cluster", "must be local, auto or ray://HOST:PORT"),
    ("10.0.0.5:6379", "a remote cluster is written ray://HOST:PORT"), ("http://head:10001", "got 'http://head:10001'"),
    ("ray://head:0", "port must be a number from 1 to 65535"), ("ray://head:99999", "from 1 to 65535"),
    ("ray://head:port", "(got 'port')"), ("ray://", "must be local, auto")])
def test_bad_cluster_values_are_one_line(text, says):
    with pytest.raises(ClusterError) as err:
        parse_cluster(text)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_the_flag_refuses_a_bad_value_with_argparse_usage(capsys):
    p = argparse.ArgumentParser(prog="gesturelsm batch")
    add_cluster_argument(p, "each video")
    assert p.parse_args([]).cluster is None
    assert p.parse_args(["--cluster", "ray://h:1"]).cluster == ClusterAddress("client", "h", 1)
    with pytest.raises(SystemExit) as stop:
        p.parse_args(["--cluster", "nowhere"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == ("gesturelsm batch: error: argument --cluster: --cluster must be local, auto or ray://HOST:PORT "
                       "(got 'nowhere') (a remote cluster is written ray://HOST:PORT)")


def test_files_travel_by_value_and_land_whole(tmp_path, monkeypatch):
    src = tmp_path / "ckpt"
    (src / "generator").mkdir(parents=True)
    (src / "generator" / "a.safetensors").write_bytes(b"weights" * 100)
    (src / "tokenizer.txt").write_text("t")
    here = Files.of(src, ship=False)
    assert not here.shipped and here.local() == src and here.digest == ""          # nothing read
    shipped = Files.of(src, ship=True)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path / "worker-tmp"))
    os.makedirs(tmp_path / "worker-tmp")
    got = shipped.local()
    assert got != src and (got / "generator" / "a.safetensors").read_bytes() == b"weights" * 100
    assert sorted(p.name for p in got.parent.iterdir()) == [shipped.digest]        # no half copy left behind
    assert shipped.local() == got                                       # once per machine
    one = Files.of(src / "tokenizer.txt", ship=True)
    assert one.local().name == "tokenizer.txt" and one.local().read_text() == "t"
    part = Files.of(src, ship=True, only=["generator/a.safetensors"])
    assert part.names == ("generator/a.safetensors",) and part.digest != shipped.digest
    assert sorted(p.name for p in part.local().iterdir()) == ["generator"]
    (src / "tokenizer.txt").write_text("changed")
    assert Files.of(src, ship=True).digest != shipped.digest
    assert Files.of(None, ship=True) is None
    from gesturelsm.constants import ASSETS

    own = Files.of(ASSETS / "generator", ship=True)                     # the package's own files stay home
    assert own.blobs is None and own.source == "generator" and own.local() == ASSETS / "generator"
    with pytest.raises(FileNotFoundError):
        Files.of(tmp_path / "missing", ship=True)


def test_write_atomic_leaves_the_old_file_or_the_new_one(tmp_path):
    target = tmp_path / "videos" / "v_1.mp4"
    write_atomic(target, b"first")
    assert target.read_bytes() == b"first" and oct(target.stat().st_mode & 0o777) == "0o644"

    with pytest.raises(TypeError):
        write_atomic(target, object())                                 # fails while writing
    assert target.read_bytes() == b"first"
    assert sorted(p.name for p in target.parent.iterdir()) == ["v_1.mp4"]   # no temporary file left


def test_tally_estimates_the_time_left_from_the_cost_done(monkeypatch):
    now = [100.0]
    monkeypatch.setattr("time.perf_counter", lambda: now[0])
    t = Tally(4, 10.0, "videos")
    assert t.seconds_left is None and t.message() == "0/4 videos"
    now[0] = 110.0
    t.finish(2.5, True)                                                # 2.5 cost units in 10 s
    assert t.seconds_left == pytest.approx(30.0) and t.fraction == 0.25
    assert t.message("v_1") == "1/4 videos, about 30s left: v_1"
    t.finish(2.5, False)
    assert "1 failed" in t.message()
    now[0] = 210.0
    t.finish(5.0, True)
    t.finish(0.0, True)
    assert t.message() == "4/4 videos, 1 failed, in 1m50s"
    assert [duration(s) for s in (5, 95, 4000)] == ["5s", "1m35s", "1h06m"]


def test_progress_line_redraws_on_a_terminal_and_logs_lines_elsewhere():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty = Tty()
    line = ProgressLine(tty)                                           # progress.Line, the one renderer
    line(0.5, "5/10 videos")
    line.write("  v_1 rendered")
    line(1.0, "10/10 videos")
    assert tty.getvalue() == ("\r\033[K[ 50 %] 5/10 videos\r\033[K  v_1 rendered\n"
                              "\r\033[K[100 %] 10/10 videos\n")
    log = io.StringIO()
    quiet = ProgressLine(log)
    for k in range(0, 41):                                             # the first, each tenth, the last
        quiet(k / 40, f"{k}/40 videos")
    assert log.getvalue().splitlines() == [f"[{100 * k / 40:3.0f} %] {k}/40 videos" for k in range(0, 41, 4)]


def test_runner_here_builds_once_lists_failures_and_keeps_going():
    written, seen = {}, []
    job = Job(units.work, units.build, 10)
    todo = [Unit(f"u{i}", i, cost=1 + i, label=f"item {i}") for i in range(6)]
    report = run_units(job, todo, lambda u, r: written.__setitem__(u.key, r), progress=lambda f, m: seen.append((f, m)),
                       noun="items")
    assert {k: v[0] for k, v in written.items()} == {"u0": 10, "u1": 11, "u2": 12, "u5": 15}
    assert len({v[1] for v in written.values()}) == 1 and list(written.values())[0][1] == os.getpid()   # built once
    assert [str(f) for f in report.failed] == ["u3 (item 3): three is not accepted",
                                               "u4 (item 4): KeyError: 'four'"]
    assert report.done == ["u0", "u1", "u2", "u5"]
    assert seen[0] == (0.0, "0/6 items") and seen[-1][0] == pytest.approx(1.0)
    assert seen[3][0] == pytest.approx(6 / 21)                          # by cost: 1 + 2 + 3 of 21
    with pytest.raises(ClusterError) as err:
        report.raise_failures("items")
    assert str(err.value).splitlines() == ["2 of 6 items failed on every try:", "  u3 (item 3): three is not accepted",
                                           "  u4 (item 4): KeyError: 'four'"]


def test_runner_here_uses_what_was_built_and_can_stop():
    got = {}
    run_units(Job(units.work, units.build, 0), [Unit("a", 1)], lambda u, r: got.__setitem__(u.key, r),
              built={"base": 100, "pid": -1})
    assert got == {"a": (101, -1)}
    asked = []
    with pytest.raises(Stopped):
        run_units(Job(units.work, units.build, 0), [Unit("a", 1), Unit("b", 2)], lambda u, r: asked.append(u.key),
                  cancelled=lambda: len(asked) == 1)
    assert asked == ["a"]
    with pytest.raises(KeyError):                                       # keep_going=False: the plain loop's error
        run_units(Job(units.work, units.build, 0), [Unit("a", 4)], lambda u, r: None, keep_going=False)
    with pytest.raises(ValueError, match="share a key"):
        run_units(Job(units.work, units.build, 0), [Unit("a", 1), Unit("a", 2)], lambda u, r: None)


def test_nothing_of_ray_is_imported_by_the_package():
    import subprocess

    code = ("import sys, gesturelsm.cluster, gesturelsm.cluster.runner, gesturelsm.cluster.connect;"
            "print(sorted(m for m in sys.modules if m == 'ray' or m.startswith('ray.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def _closed_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_cluster_is_one_line_at_once(monkeypatch):
    import time

    from gesturelsm.cluster import connect

    port = _closed_port()
    t0 = time.perf_counter()
    with pytest.raises(ClusterError) as err:
        connect(parse_cluster(f"ray://127.0.0.1:{port}"))
    assert str(err.value) == (f"cannot reach the Ray cluster at ray://127.0.0.1:{port} (connection refused): start "
                              "it with `ray start --head` there, or check the address and the firewall")
    monkeypatch.setenv("RAY_ADDRESS", f"127.0.0.1:{port}")           # `auto` finds a recorded cluster that is gone
    with pytest.raises(ClusterError, match=rf"cannot reach the Ray cluster at [\d.]+:{port}, the one recorded on this "
                                           r"machine \(or in RAY_ADDRESS\), \(connection refused\)"):
        connect(parse_cluster("auto"))
    assert time.perf_counter() - t0 < 10
    import ray

    assert not ray.is_initialized()


@pytest.mark.parametrize("text, low, high", [("1", 1, 1), ("4", 4, 4), ("2:8", 2, 8), (" 3:3 ", 3, 3)])
def test_replica_counts(text, low, high):
    from gesturelsm.cluster import parse_replicas

    got = parse_replicas(text)
    assert (got.low, got.high, got.fixed) == (low, high, low == high)
    assert str(got) == (str(low) if low == high else f"{low}:{high}")


@pytest.mark.parametrize("text, says", [("0", "give 1 to 256 replicas"), ("4:2", "MIN at most MAX"),
                                        ("two", "a whole number N or MIN:MAX (got 'two')"), ("1:2:3", "MIN:MAX"),
                                        ("-1", "(got '-1')"), ("1:", "(got '1:')"), ("300", "give 1 to 256")])
def test_bad_replica_counts_are_one_line(text, says):
    from gesturelsm.cluster import parse_replicas

    with pytest.raises(ClusterError) as err:
        parse_replicas(text)
    assert says in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("command", ["eval", "sweep", "batch", "genea"])
def test_an_unreachable_cluster_is_said_before_any_model_loads(command, tmp_path, capsys, monkeypatch):
    """eval, sweep, batch and genea submit load their models or read their speech before they connect: the
    cluster's address is tried with the arguments' checks, so `eval --cluster ray://...` to a machine that does not
    answer is one line, exit 2, before the clips are read or a model loads."""
    import soundfile as sf

    from gesturelsm.cli import main
    from gesturelsm.pipeline import GesturePipeline

    from _support import speech_like

    monkeypatch.setattr(GesturePipeline, "from_pretrained", classmethod(lambda cls, **k: pytest.fail("models")))
    (tmp_path / "speech").mkdir()
    sf.write(tmp_path / "speech" / "a.wav", speech_like(1.0), 16000)
    port = _closed_port()
    argv = {"eval": ["eval", "--data", str(tmp_path), "--methods", "gesturelsm", "--steps", "1"],
            "sweep": ["sweep", str(tmp_path / "speech" / "a.wav"), "--methods", "gesturelsm", "--steps", "1"],
            "batch": ["batch", "--audio-dir", str(tmp_path / "speech"), "--methods", "gesturelsm", "ddim"],
            "genea": ["genea", "submit", str(tmp_path / "speech"), "--samples", "1"]}[command]
    code = main(argv + ["--out", str(tmp_path / "out"), "--cluster", f"ray://127.0.0.1:{port}"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1] == (f"gesturelsm {command}: error: cannot reach the Ray cluster at ray://127.0.0.1:"
                                     f"{port} (connection refused): start it with `ray start --head` there, or check "
                                     "the address and the firewall"), err
    assert not (tmp_path / "out").exists()
