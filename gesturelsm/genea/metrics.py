"""The GENEA Leaderboard's objective metrics, as GENEALeaderboard/objective_metric's `exp_eval_metrics.py` computes
them (its definitions carried over, not its code; docs/GENEA.md lists where and why we differ).

Generated files sit in one folder named `<take>_<anything>.npz`, grouped by the take (first five '_' parts); the
human motion is `<take>.npz` in another. Every sample of every take is used (the reference's sampling 'all').

- fid_g / fid_k: Fréchet distance between Gaussians (mean, unbiased covariance) fitted to the raw axis-angle poses
  of all 55 joints (165 numbers per frame), every frame of every sample pooled, against every frame of the human
  takes; fid_k the same on frame-to-frame differences (within each file).
- var_k (DIV_k): per sample, the variance over time of each of the 165 numbers; the mean over samples and numbers.
- sample_div (DIV_sample): per take, its samples trimmed to the shortest, the variance across samples of every
  number of every frame, averaged; then averaged over takes (needs two samples of every take).
- div (DIV_pose): EMAGE's L1 diversity on joint positions (forward kinematics, no translation), pooled over samples.
- bc_m2a / bc_a2m (BA): EMAGE's beat alignment (sigma 0.3, order 7, speed threshold 0.1 of BEAT2's mean joint
  speeds, the first and last 2 s left out), weighted by each sample's length; needs the speech (--audio).
- srgr: EMAGE's semantic-relevant gesture recall (joints within 0.1 m of the human's, weighted by BEAT2's semantic
  labels); needs --sem.
- fgd: EMAGE's FGD (its skeleton-conv autoencoder on 6D rotations); needs its weights.
"""
from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.signal import argrelextrema

from ..errors import InputError
from ..metrics.leaderboard import div_k, div_sample, fd_g, fd_k, fit

KEYS = ("fgd", "fid_g", "fid_k", "bc_m2a", "bc_a2m", "srgr", "div", "var_k", "sample_div")
HEADERS = {"fgd": "FGD", "fid_g": "FD_g", "fid_k": "FD_k", "bc_m2a": "BA_m2a", "bc_a2m": "BA_a2m", "srgr": "SRGR",
           "div": "DIV_pose", "var_k": "DIV_k", "sample_div": "DIV_sample"}
UPPER_BODY = (3, 6, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21)     # EMAGE's BC joints
SIGMA, ORDER, SPEED_THRESHOLD, EDGE_FRAMES, FPS, SR = 0.3, 7, 0.10, 60, 30, 16000
SEM_WEIGHT, SRGR_THRESHOLD = 0.1672, 0.1


def read_poses(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(T, 165) float64 poses with NaN as 0 (as the reference loads them) and the file's betas."""
    try:
        with np.load(path, allow_pickle=False) as z:
            poses = np.nan_to_num(np.asarray(z["poses"], np.float64), nan=0.0)
            betas = np.asarray(z["betas"], np.float32) if "betas" in z.files else None
    except Exception as exc:
        raise InputError(f"{path}: not a BEAT2-layout npz with a 'poses' array ({exc})") from None
    if poses.ndim != 2 or poses.shape[1] != 165:
        raise InputError(f"{path}: 'poses' has shape {poses.shape}, expected (T, 165)")
    return poses, betas


@dataclass
class Pairing:
    human: dict[str, Path]                     # take -> its human motion
    generated: dict[str, list[Path]]           # take -> its samples, sorted


def pair_folders(generated: Path, human: Path) -> Pairing:
    """The takes of both folders, which must be the same (the reference stops otherwise)."""
    gen: dict[str, list[Path]] = defaultdict(list)
    for f in sorted(Path(generated).glob("*.npz")):
        parts = f.stem.split("_")
        if len(parts) >= 5:                    # the reference's grouping (five parts and more)
            gen["_".join(parts[:5])].append(f)
    hum = {f.stem: f for f in sorted(Path(human).glob("*.npz"))}
    if not gen:
        raise InputError(f"{generated}: no files named <take>_<anything>.npz (take: five '_' parts, e.g. "
                         "2_scott_0_103_103_sample1.npz)")
    missing, extra = sorted(set(hum) - set(gen)), sorted(set(gen) - set(hum))
    if missing or extra:
        raise InputError("the takes differ: " + "; ".join(
            p for p in (f"no generated files for {', '.join(missing)}" if missing else "",
                        f"no human motion ({human}/<take>.npz) for {', '.join(extra)}" if extra else "") if p))
    return Pairing(hum, dict(gen))


def pose_metrics(pairing: Pairing) -> dict[str, float]:
    """fid_g, fid_k and var_k: no network, no weights."""
    human = [read_poses(p)[0] for p in pairing.human.values()]
    samples = [read_poses(p)[0] for files in pairing.generated.values() for p in files]
    return dict(fid_g=fd_g(human, samples), fid_k=fd_k(human, samples), var_k=div_k(samples))


def sample_diversity(pairing: Pairing) -> float | None:
    """DIV_sample, or None when a take has a single sample (the reference gives none then)."""
    groups = [[read_poses(f)[0] for f in files if len(f.stem.split("_")) >= 6]    # the reference's: a suffix
              for files in pairing.generated.values()]
    return div_sample(groups)


def _gahr(a: np.ndarray, b: np.ndarray) -> float:
    """Mean over b of exp(-d^2 / 2 sigma^2), d the distance to the nearest a (EMAGE's GAHR)."""
    d = np.abs(np.asarray(b, float)[:, None] - np.asarray(a, float)[None, :]).min(axis=1)
    return float(np.exp(-d ** 2 / (2 * SIGMA ** 2)).mean())


def motion_beats(positions: np.ndarray, mean_speed: np.ndarray, t: int) -> list[np.ndarray]:
    """Per joint, beat frames (counted from frame 60) of the first `t` frames: local minima of order 7 of the speed
    (central differences) over BEAT2's mean speed, kept where the speed at the same index, counted from frame 0, is
    above 0.1: the reference compares the window's index with the whole clip's, and so do we (docs/GENEA.md)."""
    p = positions[:t].reshape(t, -1, 3)
    vel = np.concatenate([p[1:2] - p[:1], (p[2:] - p[:-2]) / 2, p[-1:] - p[-2:-1]]) * FPS
    speed = np.linalg.norm(vel, axis=2) / mean_speed
    beats = []
    for j in range(speed.shape[1]):
        above = set(np.where(speed[:, j] > SPEED_THRESHOLD)[0].tolist())
        found = argrelextrema(speed[EDGE_FRAMES:t - EDGE_FRAMES, j], np.less, order=ORDER)[0]
        beats.append(np.array([k for k in found if k in above], float))
    return beats


def beat_alignment(onsets: np.ndarray, beats: list[np.ndarray]) -> tuple[float, float] | None:
    """(a2m, m2a) of one sample over the upper-body joints (a joint without beats scores 0); None without onsets."""
    if len(onsets) == 0:
        return None
    a2m = m2a = 0.0
    for j in UPPER_BODY:
        if beats[j].size:
            times = beats[j] / FPS
            a2m += _gahr(times, onsets)
            m2a += _gahr(onsets, times)
    return a2m / len(UPPER_BODY), m2a / len(UPPER_BODY)


def speech_onsets(audio: np.ndarray, t: int) -> np.ndarray:
    """librosa onsets (hop 512, seconds) of the speech from 2 s to 2 s before the motion's end."""
    import librosa

    cut = audio[2 * SR:int((t - EDGE_FRAMES) / FPS * SR)].astype(np.float32)
    return librosa.onset.onset_detect(y=cut, sr=SR, hop_length=512, units="time") if len(cut) else np.zeros(0)


def semantic_weights(path: Path, n: int) -> np.ndarray:
    """BEAT2's semantic labels (tab-separated: label, start, end, duration, weight, comment) as a weight per frame."""
    w = np.zeros(n, np.float32)
    for line in Path(path).read_text().splitlines():
        cols = line.split("\t")
        if len(cols) < 5:
            continue
        try:
            s, e, weight = float(cols[1]), float(cols[2]), float(cols[4])
        except ValueError:
            continue
        if e > s:
            a, b = int(math.floor(s * FPS)), int(math.ceil(e * FPS))
            w[a:b] = np.maximum(w[a:b], weight)
    return w


def srgr_rate(pred: np.ndarray, human: np.ndarray, weights: np.ndarray) -> float:
    """Share of joints within 0.1 m of the human's, per frame weighted by weight / 0.1672."""
    diff = np.linalg.norm(pred.reshape(len(pred), -1, 3) - human.reshape(len(human), -1, 3), axis=2)
    success = (diff < SRGR_THRESHOLD) * (weights[:, None] / SEM_WEIGHT)
    return float(success.sum() / success.size)


def l1_sum(positions: np.ndarray) -> float:
    """EMAGE's L1div sum for one sample (divided by all samples' frames at the end)."""
    p = positions.reshape(len(positions), -1)
    return float(np.abs(p - p.mean(0)).sum())


__all__ = ["HEADERS", "KEYS", "Pairing", "beat_alignment", "fit", "l1_sum", "motion_beats", "pair_folders",
           "pose_metrics", "read_poses", "sample_diversity", "semantic_weights", "speech_onsets", "srgr_rate"]
