"""A sweep over sampling settings on one speech: every (method, steps, CFG) generated once per seed, timed, and
measured with evaluation/motion_stats.py; the CLI (`gesturelsm sweep`) and the page's Sweep tab call this.

    grid = SweepGrid(("gesturelsm", "ddim"), (1, 2, 4, 8), (1.0, 2.0, 3.0), seeds=2)
    check_grid(pipe, grid, seconds=10.0)                   # bounds, before any work
    speech = pipe.prepare_speech(audio, 16000)             # features once
    result = run_sweep(pipe, speech, grid)
    write_sweep(result, "runs/sweep", metric="wrist_speed")  # sweep.csv, sweep.md, sweep.json, sweep.png

Size bound (`SweepLimits`): at most `max_cells` (method, steps, CFG) combinations, `max_seeds` seeds, and
`max_work` seconds of motion generated in all (cells x seeds x speech seconds), so one sweep cannot hold a server.
Time per cell is the pipeline's generation time (features shared, then sampling + decoding, the paper's AITS
convention) averaged over seeds; statistics are averaged over seeds with their standard deviation as the spread.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..constants import Progress
from ..errors import GestureError, InputError
from ..pipeline import finish
from .motion_stats import (STATISTICS, SpeakerReference, SpeechContext, joint_positions, seed_spread,
                           speaker_reference, statistics_of_joints)


class SweepCancelled(GestureError):
    """The sweep was stopped on request; nothing was written."""


@dataclass(frozen=True)
class SweepLimits:
    max_cells: int = 72                 # (method, steps, CFG) combinations
    max_seeds: int = 4
    max_work: float = 1500.0            # seconds of motion generated in all: cells x seeds x speech seconds

    def describe(self) -> str:
        return (f"at most {self.max_cells} combinations, {self.max_seeds} seeds, and {self.max_work:g} s of motion in "
                f"all (combinations x seeds x speech seconds)")


@dataclass(frozen=True)
class SweepGrid:
    methods: tuple[str, ...]
    steps: tuple[int, ...]
    cfgs: tuple[float, ...]
    seeds: int = 1

    @property
    def cells(self) -> list[tuple[str, int, float]]:
        return [(m, s, c) for m in self.methods for s in self.steps for c in self.cfgs]


def parse_numbers(text: str | list | tuple, kind: type, name: str) -> tuple:
    """'1 2, 4' -> (1, 2, 4); duplicates dropped, order kept; a clear InputError for anything else."""
    parts = text.replace(",", " ").split() if isinstance(text, str) else list(text)
    out = []
    for p in parts:
        try:
            v = float(p)
        except (TypeError, ValueError):
            raise InputError(f"{name}: {p!r} is not a number") from None
        if kind is int:
            if v != int(v):
                raise InputError(f"{name}: {p!r} is not a whole number")
            v = int(v)
        if v not in out:
            out.append(v)
    return tuple(out)


def check_grid(pipe, grid: SweepGrid, seconds: float, limits: SweepLimits = SweepLimits()) -> None:
    """Every problem of a grid at once, one line each, before any work: empty lists, unknown methods, settings
    outside the method registry's bounds (`pipe.check_settings`), and the size bounds."""
    problems = [f"Give at least one {what}." for what, v in (("method", grid.methods), ("step count", grid.steps),
                                                              ("CFG scale", grid.cfgs)) if not v]
    if grid.seeds < 1 or grid.seeds > limits.max_seeds:
        problems.append(f"Seeds must be from 1 to {limits.max_seeds} (got {grid.seeds}).")
    for m in grid.methods:
        for s in grid.steps:
            for c in grid.cfgs:
                try:
                    pipe.check_settings(m, s, c)
                except GestureError as exc:
                    if str(exc) not in problems:
                        problems.append(str(exc))
    n = len(grid.cells)
    if n > limits.max_cells:
        problems.append(f"{n} combinations of method, steps and CFG; a sweep takes at most {limits.max_cells}.")
    work = n * grid.seeds * seconds
    if n and grid.seeds >= 1 and work > limits.max_work:
        problems.append(f"{n} combinations x {grid.seeds} seed(s) x {seconds:.1f} s of speech = {work:.0f} s of motion; "
                        f"a sweep makes at most {limits.max_work:g} s (fewer settings, seeds or a shorter clip).")
    if problems:
        raise InputError("\n".join(problems))


@dataclass
class SweepRun:
    method: str
    steps: int
    cfg: float
    seed: int
    seconds: float                       # generation time (pipeline.GenerationResult.generation_seconds)
    statistics: dict[str, float]
    motion: object = field(default=None, repr=False)        # MotionSequence, kept for the player
    local: np.ndarray | None = field(default=None, repr=False)   # joints without translation, for the seed spread


@dataclass
class SweepResult:
    grid: SweepGrid
    runs: list[SweepRun]
    speech_seconds: float
    text_mode: str
    reference: SpeakerReference | None
    seconds: float = 0.0                 # the whole sweep, wall clock
    grounding: bool = True               # the motions' feet were grounded (pipeline.finish)

    def cell_runs(self, cell: tuple[str, int, float]) -> list[SweepRun]:
        return [r for r in self.runs if (r.method, r.steps, r.cfg) == cell]

    def rows(self) -> list[dict]:
        """One row per cell: time and each statistic as mean and standard deviation over seeds, the seed spread."""
        rows = []
        for cell in self.grid.cells:
            runs = self.cell_runs(cell)
            if not runs:
                continue
            row: dict = {"method": cell[0], "steps": cell[1], "cfg": cell[2], "seeds": len(runs)}
            for key, vals in [("time", [r.seconds for r in runs])] + \
                             [(s.key, [r.statistics[s.key] for r in runs]) for s in STATISTICS]:
                v = np.asarray(vals, np.float64)
                ok = v[np.isfinite(v)]
                row[key] = float(ok.mean()) if len(ok) else float("nan")
                row[f"{key}_std"] = float(ok.std()) if len(ok) > 1 else float("nan")
            row["seed_spread"] = seed_spread([r.local for r in runs if r.local is not None])
            rows.append(row)
        return rows


def _units(steps: int, cfg: float) -> float:
    """Relative cost of one run for the time estimate: a network call per step (two batched with CFG) + decoding."""
    return steps * (1.5 if cfg > 0 else 1.0) + 1.0


def run_sweep(pipe, speech, grid: SweepGrid, body=None, reference: SpeakerReference | None = None,
              progress: Progress | None = None, cancelled: Callable[[], bool] | None = None,
              keep_motions: bool = True, grounding: bool = True) -> SweepResult:
    """Generate every cell once per seed from one prepared speech (pipeline.SpeechInput) and measure each motion, its
    feet grounded (pipeline.finish, without smoothing: the sampler's own motion otherwise) unless `grounding` is
    off. `cancelled()` is asked before every generation; True raises SweepCancelled. `progress(fraction, message)`
    carries the estimate of the time left."""
    reference = reference if reference is not None else speaker_reference()
    context = SpeechContext.of(speech.audio, None if reference is None else reference.mean_speed)
    jobs = [(m, s, c, k) for (m, s, c) in grid.cells for k in range(grid.seeds)]
    total = sum(_units(s, c) for _, s, c, _ in jobs) or 1.0
    done, runs, t0 = 0.0, [], time.perf_counter()
    for i, (m, s, c, k) in enumerate(jobs):
        if cancelled is not None and cancelled():
            raise SweepCancelled("The sweep was cancelled; nothing was written.")
        if progress:
            left = (time.perf_counter() - t0) / done * (total - done) if done else None
            eta = f", about {left:.0f} s left" if left is not None else ""
            progress(done / total, f"{i + 1} of {len(jobs)}: {m} {s} steps CFG {c:g} seed {k}{eta}")
        res = pipe.generate(speech, steps=s, cfg=c, seed=k, method=m)
        motion, _ = finish(res.motion.slice(0, speech.num_frames), grounding=grounding, body=body)
        world, local = joint_positions(motion, body)
        runs.append(SweepRun(m, s, c, k, res.generation_seconds, statistics_of_joints(world, local, context),
                             motion if keep_motions else None, local))
        done += _units(s, c)
    if progress:
        progress(1.0, f"{len(jobs)} motions in {time.perf_counter() - t0:.0f} s")
    return SweepResult(grid, runs, speech.duration, speech.text_mode, reference, time.perf_counter() - t0, grounding)
