"""A sweep over sampling settings on one speech: every (method, steps, CFG) generated once per seed, timed, and
measured with evaluation/motion_stats.py; the CLI (`gesturelsm sweep`) and the page's Sweep tab call this.

    grid = sweep_grid(["gesturelsm", "ddim"], "1 2 4 8", "1 2 3", 2, available=pipe.methods)   # values, all at once
    check_grid(pipe, grid, seconds=10.0)                   # size bounds, before any work
    speech = pipe.prepare_speech(audio, 16000)             # features once
    result = run_sweep(pipe, speech, grid)
    write_sweep(result, "runs/sweep", metric="wrist_speed")  # sweep.csv, sweep.md, sweep.json, sweep.png

Size bound (`SweepLimits`): at most `max_cells` (method, steps, CFG) combinations, `max_seeds` seeds, and
`max_work` seconds of motion generated in all (cells x seeds x speech seconds), so one sweep cannot hold a server.
Time per cell is the pipeline's generation time (features shared, then sampling + decoding, the paper's AITS
convention) averaged over seeds, measured after one untimed warm-up generation per method and guidance mode (the
first call of a method pays one-off costs that are not the setting's); statistics are averaged over seeds with their
standard deviation as the spread.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..body import load_body_model
from ..cluster import Connection, Files, Job, Unit, run_units
from ..constants import Progress
from ..errors import Cancellable, Cancelled, GestureError, InputError
from ..pipeline import GesturePipeline, SpeechInput
from ..settings import CLI, Asked, Limits, Names, PostProcess, Settings, grid_problems, settings_problems
from ..settings.values import method_list
from .sweep_limits import DEFAULT_CFGS, DEFAULT_STEPS, MEASURED_POST, SweepLimits, sweep_settings
from .motion_stats import (STATISTICS, SpeakerReference, SpeechContext, joint_positions, seed_spread,
                           speaker_reference, statistics_of_joints)


# the sweep was stopped on request; nothing was written
SweepCancelled = Cancelled


@dataclass(frozen=True)
class SweepGrid:
    methods: tuple[str, ...]
    steps: tuple[int, ...] = DEFAULT_STEPS
    cfgs: tuple[float, ...] = DEFAULT_CFGS
    seeds: int = 1

    @property
    def cells(self) -> list[tuple[str, int, float]]:
        return [(m, s, c) for m in self.methods for s in self.steps for c in self.cfgs]


def sweep_grid(methods, steps, cfgs, seeds, available: list[str], limits: SweepLimits = SweepLimits(),
               settings_limits: Limits = Limits(), names: Names = CLI) -> SweepGrid:
    """A grid from values as sent ("1 2, 4", lists, numbers as text or not): each checked by the settings' validator
    against every chosen method's spec and `settings_limits` (a server's step caps); every problem at once, one line
    each (InputError). `sweep_problems` with the other settings at their defaults."""
    problems: list[str] = []
    _, grid = sweep_problems({"methods": methods}, steps, cfgs, seeds, available, limits, settings_limits, names,
                             problems)
    if problems or grid is None:
        raise InputError("\n".join(problems))
    return grid


def sweep_problems(values: Mapping[str, Any], steps, cfgs, seeds, available: list[str],
                   limits: SweepLimits = SweepLimits(), settings_limits: Limits = Limits(), names: Names = CLI,
                   problems: list | None = None) -> tuple[Settings | None, SweepGrid | None]:
    """(the settings, the grid) of a sweep as sent, every problem added to `problems`, one line each: its settings
    part (`sweep_settings`: the methods, feet on the ground, transcription, language, any setting added; `values` by
    the settings' names, those missing at their defaults) by the settings' validator with the words `generate` and
    the page give, then the grid's lists against the chosen methods (`sweep_grid`'s checks). None where a problem
    was found."""
    problems = [] if problems is None else problems
    settings, found = settings_problems(Asked(**{s.name: values[s.name] for s in sweep_settings() if s.name in values}),
                                        available, settings_limits, names)
    problems += found
    chosen = list(settings.methods) if settings is not None else method_list(values.get("methods"), available, [])
    grid = grid_problems(chosen or [], steps, cfgs, seeds, limits.max_seeds, settings_limits, names, problems)
    return settings, (SweepGrid(tuple(chosen or ()), *grid) if grid is not None and chosen else None)


def check_grid(pipe, grid: SweepGrid, seconds: float, limits: SweepLimits = SweepLimits()) -> None:
    """Every problem of a grid at once, one line each, before any work: empty lists, methods not loaded, settings
    outside the methods' specs (`pipe.check_settings`, the settings' validator), and the size bounds."""
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
        problems.append(f"{n} combinations x {grid.seeds} seed(s) x {seconds:.1f} s of speech = {work:.0f} s of "
                        "motion; "
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
    seconds: float = 0.0                 # the whole sweep, wall clock (warm-up included)
    warmup_seconds: float = 0.0          # of which the untimed warm-up (`warm_up`)
    grounding: bool = True               # the motions' feet were grounded (settings.PostProcess)

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


def warm_up(pipe, speech, grid: SweepGrid, progress: Progress | None = None) -> float:
    """One untimed 1-step generation per method and guidance mode of the grid (CFG 1 runs one network pass per
    step, any other scale two in one batch), so no cell's time holds the one-off costs of a method's first call
    (allocations, kernel set-up for the speech's shapes). Returns the seconds it took."""
    t0 = time.perf_counter()
    for m in grid.methods:
        for c in {c == 1.0: c for c in grid.cfgs}.values():       # one scale of each mode
            if progress:
                progress(0.0, f"warming up {m}")
            pipe.generate(speech, steps=1, cfg=c, seed=0, method=m, output="raw")
    return time.perf_counter() - t0


@dataclass(frozen=True)
class SweepSpec:
    """What every cell of a sweep shares, sent once to each worker: the grid and the speech prepared on the driver."""
    checkpoints: tuple[Files, ...]            # what `checkpoint_sources` gave
    grid: SweepGrid
    speech: SpeechInput = field(repr=False)
    context: SpeechContext = field(repr=False)
    body: Files | None = None                 # None: the statistics' own body
    keep_motions: bool = False
    grounding: bool = True


@dataclass
class SweepBuilt:
    pipeline: object
    speech: SpeechInput
    context: SpeechContext
    body: object = None
    keep_motions: bool = True
    grounding: bool = True


def build_sweep(spec: SweepSpec) -> SweepBuilt:
    """A worker's models, warmed up (`warm_up`) before its first timed cell as in one process."""
    pipe = GesturePipeline.from_pretrained(checkpoints=[f.local() for f in spec.checkpoints] or None,
                                           methods=list(spec.grid.methods) or None)
    body = load_body_model(str(spec.body.local())) if spec.body is not None else None
    warm_up(pipe, spec.speech, spec.grid)
    return SweepBuilt(pipe, spec.speech, spec.context, body, spec.keep_motions, spec.grounding)


def sweep_cell(built: SweepBuilt, job: tuple[str, int, float, int]) -> SweepRun:
    """One unit of a sweep: (method, steps, CFG, seed) generated, timed and measured."""
    method, steps, cfg, seed = job
    res = built.pipeline.generate(built.speech, steps=steps, cfg=cfg, seed=seed, method=method, output="raw")
    post = PostProcess(**MEASURED_POST, grounding=built.grounding)          # raw motion, as MEASURES says
    motion, _ = post.apply(res.motion.slice(0, built.speech.num_frames), built.body)
    world, local = joint_positions(motion, built.body)
    return SweepRun(method, steps, cfg, seed, res.generation_seconds, statistics_of_joints(world, local, built.context),
                    motion if built.keep_motions else None, local)


def run_sweep(pipe, speech, grid: SweepGrid, body=None, reference: SpeakerReference | None = None,
              progress: Progress | None = None, cancelled: Cancellable | None = None,
              keep_motions: bool = True, grounding: bool = True, connection: Connection | None = None,
              checkpoints: list | None = None) -> SweepResult:
    """Generate every cell once per seed from one prepared speech (pipeline.SpeechInput) and measure each motion, its
    feet grounded (settings.PostProcess, without smoothing: the sampler's own motion otherwise) unless `grounding` is
    off, after `warm_up`. Each (cell, seed) is a unit of work: in this process with `pipe`, or with `connection`
    (gesturelsm.cluster) a task whose worker loads `checkpoints` (what `checkpoint_sources` gave) and warms up once.
    `cancelled` (an errors.CancelToken, or a predicate) is asked before every generation; once cancelled,
    errors.Cancelled (SweepCancelled) is raised. `progress(fraction, message)`
    carries the estimate of the time left. On a cluster, cells that fail are listed (ClusterError) after the others
    ran; here the first error stops."""
    reference = reference if reference is not None else speaker_reference()
    context = SpeechContext.of(speech.audio, None if reference is None else reference.mean_speed)
    units = [Unit(f"{m} {s} steps CFG {c:g} seed {k}", (m, s, c, k), cost=_units(s, c))
             for (m, s, c) in grid.cells for k in range(grid.seeds)]
    ship = connection is not None
    spec = SweepSpec(tuple(Files.of(p, ship) for p in (checkpoints or [])), grid, speech, context,
                     Files.of(getattr(body, "path", None), ship), keep_motions, grounding)
    runs: dict[str, SweepRun] = {}
    t0 = time.perf_counter()
    warmup_s = 0.0 if ship else warm_up(pipe, speech, grid, progress)     # on a cluster: each worker's own
    try:
        report = run_units(Job(sweep_cell, build_sweep, spec), units, lambda u, r: runs.__setitem__(u.key, r),
                           connection=connection, progress=progress, cancelled=cancelled, noun="motions",
                           built=None if ship else SweepBuilt(pipe, speech, context, body, keep_motions, grounding),
                           keep_going=ship)
    except Cancelled:
        raise Cancelled("The sweep was cancelled; nothing was written.") from None
    report.raise_failures("sweep cells")
    return SweepResult(grid, [runs[u.key] for u in units], speech.duration, speech.text_mode, reference,
                       time.perf_counter() - t0, warmup_s, grounding)
