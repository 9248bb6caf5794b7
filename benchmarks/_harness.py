"""What the benchmark scripts share: where the real data is, how many math threads they run on, a timer that reports
medians, and one row format (a markdown table row and a JSON record of the same cells).

    from _harness import BEAT2, SHARED, Rows, set_threads, timed
    set_threads(1)                                    # torch's math threads, set before any timing
    t = timed(lambda: pipe.generate(...), repeats=5, warmup=1)
    rows = Rows(["setting", "median s", "min s"])
    rows.add("8 steps", f"{t.median:.2f}", f"{t.min:.2f}")
    print(rows.markdown())                            # | setting | median s | min s | ...
    Path("out.json").write_text(rows.json())          # [{"setting": "8 steps", "median s": "0.41", ...}]

A script whose runs are not one call each times them with `Stopwatch` (`with Stopwatch() as sw: ...; sw.seconds`);
one that prints its rows as they come prints `rows.header()` once and `rows.last()` after each `add`. `json_flag`
gives a script the `--json FILE` option and `save_json` writes its tables there (one table: its records; several: a
record list per table name).

The data: $GESTURELSM_SHARED when set, else ../shared beside the checkout (the BEAT2 sample and the characters;
never copied into the repository). Scripts run as `python benchmarks/NAME.py`, which puts this folder on sys.path.
"""
from __future__ import annotations

import json
import os
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("GESTURELSM_SHARED") or REPO.parent / "shared")
BEAT2 = SHARED / "data" / "beat2"                          # smplxflame_30/, wave16k/, textgrid/, stats/
CHARACTERS = SHARED / "assets" / "characters"


def cpu_name() -> str:
    """The CPU's model name as the kernel reports it (a speed figure is quoted with the CPU it was measured on)."""
    try:
        line = next(x for x in Path("/proc/cpuinfo").read_text().splitlines() if x.startswith("model name"))
        return line.split(":", 1)[1].strip()
    except (OSError, StopIteration):
        import platform

        return platform.processor() or platform.machine()


def take_wav(name: str = "2_scott_0_2_2") -> Path:
    """A BEAT2 take's speech (16 kHz wav) in the shared data."""
    return BEAT2 / "wave16k" / f"{name}.wav"


def take_motion(name: str = "2_scott_0_1_1") -> Path:
    """A BEAT2 take's motion (SMPL-X npz) in the shared data."""
    return BEAT2 / "smplxflame_30" / f"{name}.npz"


def set_threads(n: int) -> int:
    """torch's intra-op math threads for this process (the timings depend on it); returns n."""
    import torch

    torch.set_num_threads(int(n))
    return int(n)


@dataclass(frozen=True)
class Timing:
    """Wall seconds of each timed run, with their median and minimum; this process's CPU seconds of each run."""
    runs: tuple[float, ...]
    cpu: tuple[float, ...] = ()

    @property
    def median(self) -> float:
        return statistics.median(self.runs)

    @property
    def min(self) -> float:
        return min(self.runs)

    @property
    def cpu_median(self) -> float:
        return statistics.median(self.cpu)


def timed(fn: Callable[[], object], repeats: int = 3, warmup: int = 0) -> Timing:
    """`fn` run `warmup` times untimed, then `repeats` times, each timed with the wall clock (perf_counter) and this
    process's CPU clock."""
    for _ in range(warmup):
        fn()
    runs, cpu = [], []
    for _ in range(max(1, repeats)):
        w, c = time.perf_counter(), time.process_time()
        fn()
        runs.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return Timing(tuple(runs), tuple(cpu))


class Rows:
    """A results table: named columns, rows of cells (shown as given), as markdown or JSON."""

    def __init__(self, columns: Sequence[str]):
        self.columns = list(columns)
        self.rows: list[list[str]] = []

    def add(self, *cells: object) -> None:
        if len(cells) != len(self.columns):
            raise ValueError(f"{len(cells)} cells for {len(self.columns)} columns")
        self.rows.append([str(c) for c in cells])

    def header(self) -> str:
        """The column names and the separator line."""
        return row(self.columns) + "\n|" + "---|" * len(self.columns)

    def last(self) -> str:
        """The row added last, as a markdown line."""
        return row(self.rows[-1])

    def markdown(self) -> str:
        return "\n".join([self.header()] + [row(r) for r in self.rows])

    def records(self) -> list[dict[str, str]]:
        return [dict(zip(self.columns, r)) for r in self.rows]

    def json(self) -> str:
        return json.dumps(self.records(), indent=2)


class Stopwatch:
    """Wall seconds of a `with` block (perf_counter): `with Stopwatch() as sw: ...` then `sw.seconds`; inside the
    block, `sw.elapsed` is the time so far."""

    def __enter__(self) -> "Stopwatch":
        self.start, self.seconds = time.perf_counter(), float("nan")
        return self

    def __exit__(self, *exc: object) -> None:
        self.seconds = time.perf_counter() - self.start

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start


def json_flag(parser) -> None:
    """The `--json FILE` option: also write the script's table(s) as JSON."""
    parser.add_argument("--json", metavar="FILE", default=None, help="also write the table(s) as JSON to FILE")


def save_json(path: str | Path | None, tables: Rows | dict[str, Rows]) -> None:
    """Write one table's records, or {name: records} of several tables, to `path` (nothing when it is None)."""
    if path is None:
        return
    data = tables.records() if isinstance(tables, Rows) else {k: t.records() for k, t in tables.items()}
    Path(path).write_text(json.dumps(data, indent=2) + "\n")


def row(cells: Sequence[object]) -> str:
    """One markdown table row: | a | b | c |"""
    return "| " + " | ".join(str(c) for c in cells) + " |"


__all__ = ["BEAT2", "CHARACTERS", "REPO", "Rows", "SHARED", "Stopwatch", "Timing", "json_flag", "row", "save_json",
           "set_threads", "take_motion", "take_wav", "timed"]
