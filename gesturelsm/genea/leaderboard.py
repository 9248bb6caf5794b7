"""Every column of the leaderboard's table for one system's folder (metrics.py has the definitions): the pose
metrics always, DIV_pose always (on the body given), BA with the speech, SRGR with the semantic labels, FGD with
EMAGE's weights. A column that cannot be computed is None, with one line saying why."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from ..audio import load_audio
from ..body import resolve_body
from ..errors import InputError
from ..metrics.emage_fgd import SkeletonConvEncoder, emage_features, load_emage_weights
from ..motion.rotations import axis_angle_to_rot6d
from .files import EMAGE_FILE, MEAN_SPEED_FILE
from .metrics import (KEYS, Pairing, beat_alignment, motion_beats, pair_folders, pose_metrics, read_poses,
                      sample_diversity, semantic_weights, speech_onsets, srgr_rate, l1_sum)
from .metrics import fit as _fit

FGD_EPS = 1e-6


@dataclass
class Scores:
    values: dict[str, float | None] = field(default_factory=lambda: dict.fromkeys(KEYS))
    notes: list[str] = field(default_factory=list)
    takes: int = 0
    samples: int = 0


def _file(folder: Path | None, name: str) -> Path | None:
    if folder is None:
        return None
    f = Path(folder) / name
    return f if f.is_file() else None


def fgd(pairing: Pairing, weights: Path) -> float:
    """EMAGE's FGD as the reference pools it: per sample, the first min(human, sample) frames (a whole number of 32
    frames) of both in 6D; the human's once per take (at its first sample); Fréchet distance with 1e-6 on the
    diagonals."""
    from scipy import linalg

    model = load_emage_weights(SkeletonConvEncoder(), weights)

    def feats(p: np.ndarray) -> np.ndarray:
        six = axis_angle_to_rot6d(torch.from_numpy(p).float().reshape(len(p), 55, 3)).reshape(len(p), 330)
        return emage_features(model, six.numpy())

    pred, target = [], []
    for take, files in pairing.generated.items():
        human = read_poses(pairing.human[take])[0]
        for i, f in enumerate(files):
            g = read_poses(f)[0]
            t = min(len(g), len(human))
            t -= t % 32
            if t == 0:
                raise InputError(f"{f.name}: fewer than 32 frames; FGD needs at least 32")
            pred.append(feats(g[:t]))
            if i == 0:
                target.append(feats(human[:t]))
    a, b = _fit(np.concatenate(pred)), _fit(np.concatenate(target))
    off = np.eye(len(a.mean)) * FGD_EPS
    covmean = np.real(linalg.sqrtm((a.cov + off) @ (b.cov + off)))
    d = a.mean - b.mean
    return float(d @ d + np.trace(a.cov) + np.trace(b.cov) - 2 * np.trace(covmean))


def positional(pairing: Pairing, scores: Scores, body, audio_dir: Path | None, sem_dir: Path | None,
               mean_speed: np.ndarray | None) -> None:
    """DIV_pose, BA and SRGR: per sample, its first t = min(human, sample) frames, joints without translation."""
    l1 = frames = 0.0
    a2m = m2a = weight = 0.0
    srgr = srgr_frames = 0.0
    for take, files in pairing.generated.items():
        human, betas = read_poses(pairing.human[take])
        audio = load_audio(_file(audio_dir, f"{take}.wav")) if _file(audio_dir, f"{take}.wav") else None
        sem = _file(sem_dir, f"{take}.txt")
        for f in files:
            g = read_poses(f)[0]
            t = min(len(g), len(human))
            zero = np.zeros((t, 3), np.float32)
            pos = body.joints(g[:t], zero, betas=betas).reshape(t, -1).astype(np.float64)
            l1 += l1_sum(pos)
            frames += t
            if audio is not None and mean_speed is not None and t > 2 * 60 + 2:
                ba = beat_alignment(speech_onsets(audio, t), motion_beats(pos, mean_speed, t))
                if ba is not None:
                    a2m, m2a, weight = a2m + ba[0] * (t - 120), m2a + ba[1] * (t - 120), weight + (t - 120)
            if sem is not None:
                ref = body.joints(human[:t], zero, betas=betas).reshape(t, -1)
                srgr += srgr_rate(pos, ref, semantic_weights(sem, t)) * t
                srgr_frames += t
    scores.values["div"] = l1 / frames if frames else None
    if weight:
        scores.values["bc_a2m"], scores.values["bc_m2a"] = a2m / weight, m2a / weight
    if srgr_frames:
        scores.values["srgr"] = srgr / srgr_frames


def evaluate(generated: Path, human: Path, audio: Path | None = None, sem: Path | None = None,
             fgd_weights: Path | None = None, body=None, mean_speed: Path | None = None) -> Scores:
    pairing = pair_folders(generated, human)
    s = Scores(takes=len(pairing.human), samples=sum(len(v) for v in pairing.generated.values()))
    s.values.update(pose_metrics(pairing))
    s.values["sample_div"] = sample_diversity(pairing)
    if s.values["sample_div"] is None:
        s.notes.append("DIV_sample left out: a take has a single sample (<take>_<sample>.npz, two or more per take)")
    speeds = None
    if audio is not None:
        path = mean_speed or _file(Path(human).parent / "stats", MEAN_SPEED_FILE)
        if path is None:
            s.notes.append(f"BA left out: BEAT2's {MEAN_SPEED_FILE} not found (--mean-speed FILE)")
        else:
            speeds = np.load(path, allow_pickle=False).astype(np.float64)
    else:
        s.notes.append("BA left out: no speech given (--audio DIR with <take>.wav)")
    if sem is None:
        s.notes.append("SRGR left out: no semantic labels given (--sem DIR with <take>.txt)")
    positional(pairing, s, resolve_body(body), audio, sem, speeds)
    if audio is not None and speeds is not None and s.values["bc_a2m"] is None:
        s.notes.append("BA left out: no take had its <take>.wav, speech onsets and over 4 s of motion")
    if sem is not None and s.values["srgr"] is None:
        s.notes.append(f"SRGR left out: no <take>.txt in {sem}")
    weights = fgd_weights if fgd_weights is None or Path(fgd_weights).is_file() else _file(fgd_weights, EMAGE_FILE)
    if weights is None:
        s.notes.append(f"FGD left out: EMAGE's autoencoder weights ({EMAGE_FILE}) not given (--fgd-weights DIR)")
    else:
        s.values["fgd"] = fgd(pairing, weights)
    return s


__all__ = ["EMAGE_FILE", "MEAN_SPEED_FILE", "Scores", "evaluate", "fgd", "positional"]
