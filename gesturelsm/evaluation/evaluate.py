"""Paper-style evaluation of generators on held-out clips: FGD, BC beside ground truth's BC, L1 diversity,
face error, jitter, feet and root (metrics/feet.py: foot skate, contact share, drift, range, bob, floor
penetration, leg jerk), wrist amplitude (metrics/amplitude.py) and generation time, for every (method, steps,
CFG) of a plan.

    clips, policy = heldout_clips("../shared/data/beat2")
    report = evaluate(GesturePipeline.from_pretrained(), clips, plan_grid(["gesturelsm"], [1, 2, 4, 8], [2.0]))

Conventions:
- Joint positions come from the body model's forward kinematics (default: the built-in mannequin; a real
  SMPL-X with `body=load_body_model(path)`), metres, 30 fps.
- FGD rows: ground truth's held-out clips vs the motions generated for the same clips (all seeds pooled);
  features per 32-frame window (see metrics/motion_features.py), EMAGE's latents when its weights are given.
- BC: speeds normalised by per-joint mean speeds of the ground-truth motion of the folder on the same body
  (or `mean_speed`, e.g. BEAT2's mean_vel_smplxflame_30.npy when the body is the real SMPL-X).
- Averages: per clip, then over clips and seeds. Clips with motion and audio-only clips are reported apart.
- Each clip is a unit of work (every plan item and seed on it): in this process, or as a task on a Ray cluster
  (`gesturelsm eval --cluster`, gesturelsm.cluster) whose worker gets the body model, the feature extractors and the
  reference speeds by value; the report is assembled here in clip order either way.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np

from ..body import load_body_model
from ..cluster import Connection, Files, Job, Unit, run_units
from ..constants import SAMPLE_RATE
from ..metrics import leaderboard as lb
from ..metrics.amplitude import amplitude_stats
from ..metrics.beat import audio_beats, beat_consistency, joint_speed
from ..metrics.diversity import l1_diversity
from ..metrics.face import expression_mse, face_vertex_mse
from ..metrics.fgd import default_extractors, fgd
from ..metrics.feet import FeetStats, feet_stats
from ..metrics.physics import jitter
from ..pipeline import GesturePipeline
from .clips import EvalClip

Log = Callable[[str], None]


@dataclass(frozen=True)
class EvalPlanItem:
    method: str
    steps: int
    cfg: float

    @property
    def label(self) -> str:
        return f"{self.method} {self.steps} steps, CFG {self.cfg:g}"


AMPLITUDE_KEYS = ("raised_share", "height_p95", "wrist_speed", "hand_spread")   # means over clips x seeds
FEET_KEYS = tuple(FeetStats.__dataclass_fields__)                                 # metrics/feet.py, the same


def plan_grid(methods: list[str], steps: list[int], cfgs: list[float]) -> list[EvalPlanItem]:
    return [EvalPlanItem(m, int(s), float(c)) for m in methods for s in steps for c in cfgs]


@dataclass
class MotionStats:
    """Per-motion measurements (one clip, one seed); FGD features are kept for pooling."""
    bc: float
    diversity: float
    jitter: float
    feet: dict[str, float]                                        # metrics.feet.FeetStats fields
    features: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    expr_mse: float | None = None
    vertex_mse: float | None = None
    amplitude: dict[str, float] = field(default_factory=dict)   # metrics.amplitude.AmplitudeStats fields
    poses: np.ndarray | None = field(default=None, repr=False)   # (T, 165): the GENEA Leaderboard's pose columns
    clip: str = ""                                               # which clip (its seeds are one speech's samples)


def motion_stats(motion, body, beats: np.ndarray, mean_speed: np.ndarray, extractors, gt=None,
                 face_vertices: bool = False) -> MotionStats:
    zero = np.zeros((motion.num_frames, 3), np.float32)
    world = body.joints(motion.poses, motion.trans)                             # (T, 55, 3)
    local = body.joints(motion.poses, zero)                                     # translation removed
    s = MotionStats(beat_consistency(world, beats=beats, mean_speed=mean_speed), l1_diversity(local),
                    jitter(world), feet_stats(world).as_dict(), amplitude=amplitude_stats(world).as_dict(),
                    poses=np.asarray(motion.poses, np.float32))
    for ex in extractors:
        if len(local) >= 32:
            s.features[ex.name] = ex(motion, local)
    if gt is not None:
        s.expr_mse = expression_mse(motion.expressions, gt.expressions)
        if face_vertices:
            s.vertex_mse = face_vertex_mse(body, motion, gt)
    return s


def _mean(vals) -> float | None:
    v = [x for x in vals if x is not None and np.isfinite(x)]
    return float(np.mean(v)) if v else None


def summarise(stats: list[MotionStats], gt_stats: list[MotionStats] | None, extractors) -> dict:
    out = {"bc": _mean(s.bc for s in stats), "diversity": _mean(s.diversity for s in stats),
           "jitter": _mean(s.jitter for s in stats), **{k: _mean(s.feet.get(k) for s in stats) for k in FEET_KEYS},
           "expr_mse": _mean(s.expr_mse for s in stats), "vertex_mse": _mean(s.vertex_mse for s in stats),
           **{k: _mean(s.amplitude.get(k) for s in stats) for k in AMPLITUDE_KEYS}}
    if gt_stats:
        for ex in extractors:
            real = [g.features[ex.name] for g in gt_stats if ex.name in g.features]
            gen = [s.features[ex.name] for s in stats if ex.name in s.features]
            ok = sum(len(r) for r in real) >= 2 and sum(len(g) for g in gen) >= 2
            out[ex.name] = fgd(real, gen, normalize=ex.name != "fgd_emage") if ok else None
    out.update(genea_columns(stats, gt_stats))
    return out


def genea_columns(stats: list[MotionStats], gt_stats: list[MotionStats] | None) -> dict:
    """The GENEA Leaderboard's pose columns (metrics/leaderboard.py; the seeds of a clip are its samples): FD_g and
    FD_k against the ground truth's clips, DIV_k, and DIV_sample (None with one seed)."""
    gen = [s.poses for s in stats if s.poses is not None and len(s.poses) > 2]
    out = dict(fid_g=None, fid_k=None, var_k=lb.div_k(gen) if gen else None, sample_div=None)
    groups: dict[str, list] = {}
    for s in stats:
        if s.poses is not None and s.clip:          # ground truth's clips are no one speech's samples
            groups.setdefault(s.clip, []).append(s.poses)
    if groups and all(len(g) >= 2 for g in groups.values()):
        out["sample_div"] = lb.div_sample(list(groups.values()))
    real = [g.poses for g in gt_stats or [] if g.poses is not None and len(g.poses) > 2]
    if real and gen and sum(map(len, real)) > 2 and sum(map(len, gen)) > 2:
        out["fid_g"], out["fid_k"] = lb.fd_g(real, gen), lb.fd_k(real, gen)
    return out


def evaluate(pipe, clips: list[EvalClip], plan: list[EvalPlanItem], seeds: int = 1, body=None,
             extractors=None, mean_speed: np.ndarray | None = None, face_vertices: bool = False,
             log: Log | None = None, connection: Connection | None = None, checkpoints: list | None = None) -> dict:
    """-> report dict (JSON-ready): ground truth summary, one row per plan item, clip list, settings. With
    `connection` each clip is a task on its cluster, whose worker loads `checkpoints` (what `checkpoint_sources`
    gave); clips that fail are listed (ClusterError) after the others ran."""
    log = log or (lambda m: None)
    body = body or load_body_model()
    extractors = default_extractors() if extractors is None else extractors
    with_motion = [c for c in clips if c.motion is not None]
    if mean_speed is None:
        if with_motion:
            sp = [joint_speed(body.joints(c.motion.poses, c.motion.trans)) for c in with_motion]
            mean_speed = np.concatenate(sp).mean(0)
        else:
            mean_speed = None            # each motion normalised by its own mean speed
    beats = {c.name: audio_beats(c.audio) for c in with_motion}
    gt_stats = [motion_stats(c.motion, body, beats[c.name], mean_speed, extractors) for c in with_motion]
    report: dict = {
        "clips": [{"name": c.name, "seconds": round(c.duration, 2), "ground_truth": c.motion is not None,
                   "transcript": c.words is not None} for c in clips],
        "ground_truth": summarise(gt_stats, None, extractors) if gt_stats else None,
        "rows": [], "seeds": seeds, "extractors": [e.name for e in extractors],
    }
    ship = connection is not None
    spec = EvalSpec(tuple(Files.of(p, ship) for p in (checkpoints or [])), tuple(dict.fromkeys(i.method for i in plan)),
                    tuple(plan), seeds, body, tuple(extractors), mean_speed, face_vertices)
    units = [Unit(f"{i + 1}/{len(clips)} {c.name}", c, cost=c.duration) for i, c in enumerate(clips)]
    got: dict[str, list] = {}

    def done(unit: Unit, rows: list) -> None:
        got[unit.key] = rows
        log(f"clip {unit.key}: done")

    report_units = run_units(Job(eval_clip, build_eval, spec), units, done, connection=connection,
                             built=None if ship else EvalBuilt(pipe, spec), keep_going=ship, noun="clips")
    report_units.raise_failures("clips")
    for j, item in enumerate(plan):
        runs = [run for u in units for run in got[u.key][j]]           # clip order, then seeds
        st_m = [st for st, _, _, with_gt in runs if with_gt]
        st_a = [st for st, _, _, with_gt in runs if not with_gt]
        gen_s, dur = [g for _, g, _, _ in runs], [d for _, _, d, _ in runs]
        row = {**asdict(item), "heldout": summarise(st_m, gt_stats, extractors) if st_m else None,
               "audio_only": summarise(st_a, None, extractors) if st_a else None,
               "seconds_per_clip": float(np.mean(gen_s)), "clip_seconds": float(np.mean(dur)),
               "real_time_factor": float(np.sum(dur) / max(np.sum(gen_s), 1e-9))}
        report["rows"].append(row)
    return report


@dataclass(frozen=True)
class EvalSpec:
    """What every clip of an evaluation shares, sent once to each worker."""
    checkpoints: tuple[Files, ...]            # what `checkpoint_sources` gave
    methods: tuple[str, ...]
    plan: tuple[EvalPlanItem, ...]
    seeds: int
    body: object = field(repr=False)          # the body model every metric's joints come from
    extractors: tuple = field(repr=False)     # FGD feature extractors
    mean_speed: np.ndarray | None = field(default=None, repr=False)
    face_vertices: bool = False


@dataclass
class EvalBuilt:
    pipeline: object
    spec: EvalSpec


def build_eval(spec: EvalSpec) -> EvalBuilt:
    return EvalBuilt(GesturePipeline.from_pretrained(checkpoints=[f.local() for f in spec.checkpoints] or None,
                                                     methods=list(spec.methods) or None), spec)


def eval_clip(built: EvalBuilt, clip: EvalClip) -> list[list[tuple[MotionStats, float, float, bool]]]:
    """One unit of an evaluation: every plan item and seed on one clip; per item, per seed: (the motion's stats,
    generation seconds, motion seconds, measured against ground truth)."""
    spec, pipe = built.spec, built.pipeline
    beats = audio_beats(clip.audio)
    speech = pipe.prepare_speech(clip.audio, SAMPLE_RATE, words=clip.words)
    rows = []
    for item in spec.plan:
        per_seed = []
        for seed in range(spec.seeds):
            res = pipe.generate(speech, steps=item.steps, cfg=item.cfg, seed=seed, method=item.method, output="raw")
            m, gt = res.motion, None
            if clip.motion is not None:
                n = min(m.num_frames, clip.motion.num_frames)
                m, gt = m.slice(0, n), clip.motion.slice(0, n)
            stats = motion_stats(m, spec.body, beats, spec.mean_speed, list(spec.extractors), gt, spec.face_vertices)
            stats.clip = clip.name
            per_seed.append((stats, res.generation_seconds, res.motion.duration, gt is not None))
        rows.append(per_seed)
    return rows
