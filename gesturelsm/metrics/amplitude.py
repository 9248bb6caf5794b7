"""Does the motion use the speaker's space? Wrist amplitude statistics and a replay guard.

Input everywhere: (T, 55, 3) joint positions from the body model's forward kinematics, SMPL-X joint order,
metres, **y up**, 30 fps. Wrists are measured relative to the pelvis (joint 0), so walking or a root offset
does not count as gesture.

| statistic | definition | unit |
|---|---|---|
| raised share | share of frames where either wrist is above pelvis + `raised_m` (0.25 m: about navel height) | 0..1 |
| wrist height p50 / p95 | median / 95th percentile over frames of the higher wrist's height above the pelvis | m |
| wrist speed | mean speed of both wrists relative to the pelvis | m/s |
| hand spread | mean distance between the wrists | m |
| jerk | mean joint jerk of the upper body (third difference), as `physics.jitter` | m/s^3 |

Replay guard (`replay_novelty`): motion that copies training clips would match the speaker's statistics
perfectly. For 1 s windows of upper-body motion (pelvis-relative positions of the upper-body joints, every
3rd frame), the RMS distance (m) to the nearest 1 s window of the *training* motion; the guard is the median
of that over the generated windows divided by the same median for the speaker's own held-out motion. Copied
training clips score ~0; motion as new as the speaker's own new motion scores ~1.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import torch

from ..constants import FPS
from ..errors import InputError
from ..motion.regions import REGIONS

PELVIS, LEFT_WRIST, RIGHT_WRIST = 0, 20, 21
RAISED_M = 0.25


@dataclass(frozen=True)
class AmplitudeStats:
    raised_share: float      # 0..1
    height_p50: float        # m above the pelvis, higher wrist
    height_p95: float        # m
    wrist_speed: float       # m/s, both wrists, pelvis-relative
    hand_spread: float       # m between the wrists
    jerk: float              # m/s^3, upper-body joints

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def wrist_heights(joints: np.ndarray) -> np.ndarray:
    """(T, 55, 3) -> (T, 2) height (m) of the left and right wrist above the pelvis (y up)."""
    j = np.asarray(joints, np.float64)
    return j[:, [LEFT_WRIST, RIGHT_WRIST], 1] - j[:, [PELVIS], 1]


def amplitude_stats(joints: np.ndarray, fps: int = FPS, raised_m: float = RAISED_M) -> AmplitudeStats:
    """Wrist amplitude statistics of one motion (see the module table)."""
    j = np.asarray(joints, np.float64)
    if j.ndim != 3 or j.shape[1:] != (55, 3) or len(j) < 4:
        raise ValueError(f"expected (T >= 4, 55, 3) joint positions, got {j.shape}")
    h = wrist_heights(j).max(axis=1)                                          # (T,) higher wrist
    rel = j[:, [LEFT_WRIST, RIGHT_WRIST]] - j[:, [PELVIS]]                    # (T, 2, 3) pelvis-relative
    speed = np.linalg.norm(np.diff(rel, axis=0), axis=-1) * fps               # (T-1, 2)
    spread = np.linalg.norm(j[:, LEFT_WRIST] - j[:, RIGHT_WRIST], axis=-1)    # (T,)
    upper = list(REGIONS["upper"].joints)
    d3 = j[3:, upper] - 3 * j[2:-1, upper] + 3 * j[1:-2, upper] - j[:-3, upper]
    jerk = np.linalg.norm(d3, axis=-1).mean() * fps ** 3
    return AmplitudeStats(float((h > raised_m).mean()), float(np.percentile(h, 50)), float(np.percentile(h, 95)),
                          float(speed.mean()), float(spread.mean()), float(jerk))


def pooled_stats(motions: list[np.ndarray], fps: int = FPS) -> AmplitudeStats:
    """Statistics of several motions, each weighted by its length (frames pooled; speeds and jerk per motion,
    averaged with weights T)."""
    if not motions:
        raise InputError("no motions to pool")
    per = [amplitude_stats(m, fps) for m in motions]
    w = np.array([len(m) for m in motions], np.float64)
    h = np.concatenate([wrist_heights(m).max(axis=1) for m in motions])
    mean = lambda k: float(np.average([getattr(p, k) for p in per], weights=w))  # noqa: E731
    return AmplitudeStats(float(np.average([p.raised_share for p in per], weights=w)),
                          float(np.percentile(h, 50)), float(np.percentile(h, 95)),
                          mean("wrist_speed"), mean("hand_spread"), mean("jerk"))


def upper_windows(joints: np.ndarray, window: int = FPS, stride: int = 1, every: int = 3) -> torch.Tensor:
    """(T, 55, 3) -> (N, window // every * 13 * 3) flattened pelvis-relative upper-body positions of every
    `window`-frame window starting at multiples of `stride` (frames subsampled by `every`)."""
    j = np.asarray(joints, np.float32)
    rel = j[:, list(REGIONS["upper"].joints)] - j[:, [PELVIS]]                # (T, 13, 3)
    starts = range(0, len(j) - window + 1, stride)
    if len(starts) == 0:
        raise InputError(f"motion of {len(j)} frames is shorter than one {window}-frame window")
    return torch.from_numpy(np.stack([rel[s:s + window:every].reshape(-1) for s in starts]))


def nearest_distances(query: torch.Tensor, bank: torch.Tensor, chunk: int = 512) -> np.ndarray:
    """(N, F), (M, F) -> (N,) RMS distance (m per coordinate) of each query row to its nearest bank row."""
    out = []
    for a in range(0, len(query), chunk):
        d = torch.cdist(query[a:a + chunk].double(), bank.double())           # (n, M) Euclidean
        out.append(d.min(dim=1).values)
    return (torch.cat(out) / np.sqrt(query.shape[1])).numpy()


@dataclass(frozen=True)
class ReplayGuard:
    generated: float         # median nearest-training-window distance of the generated windows, m
    reference: float         # the same for the speaker's held-out motion, m
    ratio: float             # generated / reference: ~0 copies training, ~1 as new as the speaker


def training_bank(train_motions: list[np.ndarray], window: int = FPS) -> torch.Tensor:
    """All 1 s windows (stride 1) of the training motions, for `replay_novelty`."""
    return torch.cat([upper_windows(m, window, stride=1) for m in train_motions])


def replay_novelty(generated: list[np.ndarray], bank: torch.Tensor, reference: list[np.ndarray],
                   window: int = FPS, stride: int = 5) -> ReplayGuard:
    """Median nearest-training-window distance of `generated` over that of `reference` (the speaker's
    held-out motion); `bank` from `training_bank`. Query windows start every `stride` frames."""
    def med(motions: list[np.ndarray]) -> float:
        q = torch.cat([upper_windows(m, window, stride) for m in motions])
        return float(np.median(nearest_distances(q, bank)))

    g, r = med(generated), med(reference)
    return ReplayGuard(g, r, g / max(r, 1e-12))
