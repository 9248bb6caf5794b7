"""Paper-style evaluation of generators on held-out clips: FGD, BC beside ground truth's BC, L1 diversity,
face error, jitter, feet and root (metrics/feet.py: foot skate, contact share, drift, range, bob, floor
penetration, leg jerk), wrist amplitude (metrics/amplitude.py) and generation time, for every (method, steps, CFG) of a plan.

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
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np

from ..body import load_body_model
from ..constants import SAMPLE_RATE
from ..metrics.amplitude import amplitude_stats
from ..metrics.beat import audio_beats, beat_consistency, joint_speed
from ..metrics.diversity import l1_diversity
from ..metrics.face import expression_mse, face_vertex_mse
from ..metrics.fgd import default_extractors, fgd
from ..metrics.feet import FeetStats, feet_stats
from ..metrics.physics import jitter
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


def motion_stats(motion, body, beats: np.ndarray, mean_speed: np.ndarray, extractors, gt=None,
                 face_vertices: bool = False) -> MotionStats:
    zero = np.zeros((motion.num_frames, 3), np.float32)
    world = body.joints(motion.poses, motion.trans)                             # (T, 55, 3)
    local = body.joints(motion.poses, zero)                                     # translation removed
    s = MotionStats(beat_consistency(world, beats=beats, mean_speed=mean_speed), l1_diversity(local),
                    jitter(world), feet_stats(world).as_dict(), amplitude=amplitude_stats(world).as_dict())
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
    return out


def evaluate(pipe, clips: list[EvalClip], plan: list[EvalPlanItem], seeds: int = 1, body=None,
             extractors=None, mean_speed: np.ndarray | None = None, face_vertices: bool = False,
             log: Log | None = None) -> dict:
    """-> report dict (JSON-ready): ground truth summary, one row per plan item, clip list, settings."""
    log = log or (lambda m: None)
    body = body or load_body_model()
    extractors = default_extractors() if extractors is None else extractors
    with_motion = [c for c in clips if c.motion is not None]
    audio_only = [c for c in clips if c.motion is None]
    if mean_speed is None:
        if with_motion:
            sp = [joint_speed(body.joints(c.motion.poses, c.motion.trans)) for c in with_motion]
            mean_speed = np.concatenate(sp).mean(0)
        else:
            mean_speed = None            # each motion normalised by its own mean speed
    beats = {c.name: audio_beats(c.audio) for c in clips}
    gt_stats = [motion_stats(c.motion, body, beats[c.name], mean_speed, extractors) for c in with_motion]
    report: dict = {
        "clips": [{"name": c.name, "seconds": round(c.duration, 2), "ground_truth": c.motion is not None,
                   "transcript": c.words is not None} for c in clips],
        "ground_truth": summarise(gt_stats, None, extractors) if gt_stats else None,
        "rows": [], "seeds": seeds, "extractors": [e.name for e in extractors],
    }
    speech = {c.name: pipe.prepare_speech(c.audio, SAMPLE_RATE, words=c.words) for c in clips}
    for item in plan:
        t0 = time.perf_counter()
        st_m, st_a, gen_s, dur = [], [], [], []
        for c in clips:
            for seed in range(seeds):
                res = pipe.generate(speech[c.name], steps=item.steps, cfg=item.cfg, seed=seed, method=item.method)
                gen_s.append(res.generation_seconds)
                dur.append(res.motion.duration)
                m = res.motion
                gt = None
                if c.motion is not None:
                    n = min(m.num_frames, c.motion.num_frames)
                    m, gt = m.slice(0, n), c.motion.slice(0, n)
                s = motion_stats(m, body, beats[c.name], mean_speed, extractors, gt, face_vertices)
                (st_m if gt is not None else st_a).append(s)
        row = {**asdict(item), "heldout": summarise(st_m, gt_stats, extractors) if st_m else None,
               "audio_only": summarise(st_a, None, extractors) if st_a else None,
               "seconds_per_clip": float(np.mean(gen_s)), "clip_seconds": float(np.mean(dur)),
               "real_time_factor": float(np.sum(dur) / max(np.sum(gen_s), 1e-9))}
        report["rows"].append(row)
        log(f"{item.label}: done in {time.perf_counter() - t0:.1f} s")
    return report
