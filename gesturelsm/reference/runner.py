"""Run converted authors' models on any length of speech, in the shared window loop (`flows.windows`).

Windows of 128 frames (4.27 s) advance by 112 frames; each window's seed is the last 4 latent frames of
the previous one, and the overlap keeps the previous window's latents, as in the reference. Unlike the reference (first
seed taken from a ground-truth file, trailing frames dropped, 63 s cap), the first seed is *neutral*: the RVQ encoding
of the speaker's mean pose standing still; the audio is padded to whole windows and the output cut to the speech's
length. Face: the released configs generate none, so jaw and expressions stay neutral (identity jaw, zeros).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..constants import Progress
from ..flows import Held, sample_windows, window_layout
from ..motion.regions import REGIONS as MOTION_REGIONS
from ..motion.regions import join_regions
from ..motion.sequence import MotionSequence
from .config import LATENT_SCALE, REGIONS, SAMPLES_PER_FRAME
from .model import ReferenceGenerator
from .rvq import ReferenceRVQ
from .speech import speech_features, word_tokens

# joint lists of the reference's region masks (utils/joints.py), also our regions.py order
REGION_JOINTS = {"upper": (3, 6, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21), "hands": tuple(range(25, 55)),
                 "lower": (0, 1, 2, 4, 5, 7, 8, 10, 11)}
FACE_NOTE = "face neutral: the authors' released models generate no face"


def _cols(region: str) -> list[int]:
    return [6 * j + k for j in REGION_JOINTS[region] for k in range(6)]


@dataclass
class ReferenceBundle:
    """The three RVQ-VAEs with the normalisation statistics (shared by every authors' method)."""
    rvqs: dict[str, ReferenceRVQ]
    stats: dict[str, torch.Tensor]

    def normalise(self, region: str, x: torch.Tensor) -> torch.Tensor:
        m, s = self.stats["mean"][_cols(region)], self.stats["std"][_cols(region)]
        if region == "lower":
            m = torch.cat([m, self.stats["trans_mean"]])
            s = torch.cat([s, self.stats["trans_std"]])
        return (x - m) / s

    def denormalise(self, region: str, z: torch.Tensor) -> torch.Tensor:
        m, s = self.stats["mean"][_cols(region)], self.stats["std"][_cols(region)]
        if region == "lower":
            m = torch.cat([m, self.stats["trans_mean"]])
            s = torch.cat([s, self.stats["trans_std"]])
        return z * s + m

    def neutral_seed(self, frames: int = 4) -> torch.Tensor:
        """(1, frames, 3 * code_dim): latents of the mean pose standing still (middle of a 128-frame clip)."""
        out = []
        for r in REGIONS:
            x = torch.zeros(1, 128, self.rvqs[r].cfg.input_dim)      # normalised zeros = mean pose
            if r == "lower":                                        # no horizontal motion: raw dx = dz = 0
                x[..., -3] = -self.stats["trans_mean"][0] / self.stats["trans_std"][0]
                x[..., -1] = -self.stats["trans_mean"][2] / self.stats["trans_std"][2]
            z = self.rvqs[r].encode(x)
            mid = z.shape[1] // 2
            out.append(z[:, mid - frames // 2: mid - frames // 2 + frames])
        return torch.cat(out, -1) / LATENT_SCALE

    def encode(self, feats: torch.Tensor) -> torch.Tensor:
        """(T, 433) raw features (ours: the same 6D rows and [dx, y, dz] as theirs) -> (1, ceil(T/4), 3 * code_dim)
        generator latents, the encoder output before quantisation / LATENT_SCALE (what their generator samples)."""
        pad = (-feats.shape[0]) % 4
        feats = torch.cat([feats, feats[-1:].expand(pad, -1)]) if pad else feats
        out = [self.rvqs[r].encode(self.normalise(r, feats[:, list(MOTION_REGIONS[r].columns)])[None])
               for r in REGIONS]
        return torch.cat(out, -1) / LATENT_SCALE

    def decode(self, latents: torch.Tensor, num_frames: int) -> MotionSequence:
        """(1, N, 3 * code_dim) generator latents -> motion (jaw, eyes, face neutral)."""
        parts, d = {}, self.rvqs["upper"].cfg.code_dim
        for i, r in enumerate(REGIONS):
            decoded = self.rvqs[r].decode(latents[..., i * d:(i + 1) * d] * LATENT_SCALE)
            parts[r] = self.denormalise(r, decoded)[0, :num_frames]
        parts["face"] = torch.zeros(num_frames, 106)
        parts["face"][:, [0, 4]] = 1.0                                 # identity 6D jaw, zero expressions
        return MotionSequence.from_features(join_regions(parts))


@torch.no_grad()
def generate_reference(bundle: ReferenceBundle, model: ReferenceGenerator, word2index: dict[str, int],
                       audio: np.ndarray,
                       num_frames: int, words: list | None, steps: int, cfg_scale: float, seed: int,
                       progress: Progress | None = None, held: Held | None = None
                       ) -> tuple[torch.Tensor, MotionSequence | None]:
    """16 kHz speech -> (latents (1, N, 384), motion of num_frames frames). `held`: known latents (1, N, 384) and
    their mask, held while sampling (edits: only windows with latents to regenerate are sampled); the motion is
    then left to the caller to decode (None)."""
    c = model.cfg
    W, L = c.frames, -(-num_frames // 4)                              # 128 frames = 32 latents per window
    starts = window_layout(L, c.seq_len, c.seed_frames)              # windows advance by 112 frames
    total = 4 * (starts[-1] + c.seq_len)                              # frames covered, padding included
    feats = speech_features(audio)                                    # (samples, 2)
    need = total * SAMPLES_PER_FRAME
    feats = np.pad(feats, ((0, max(0, need - len(feats))), (0, 0)))[:need]
    intervals = [(w.start, w.end, w.text.lower()) for w in (words or [])]
    toks = word_tokens(intervals, total, word2index)

    def sample(i: int, st: int, seed_lat: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
        f0 = 4 * st                                                   # the window's first frame
        a = torch.from_numpy(feats[f0 * SAMPLES_PER_FRAME:(f0 + W) * SAMPLES_PER_FRAME]).float()[None]
        w = torch.from_numpy(toks[f0:f0 + W])[None]
        noise = torch.randn(1, c.regions * c.input_dim, c.seq_len, generator=gen)
        hold = None
        if padded is not None:
            win = padded.window(st, c.seq_len)
            hold = (win.known.transpose(1, 2), win.mask.expand_as(win.known).transpose(1, 2))
        return model.sample(a, w, seed_lat, noise, steps=steps, cfg_scale=cfg_scale,
                            hold=hold).transpose(1, 2)                                            # (1, 32, 384)

    padded = held.padded(starts[-1] + c.seq_len) if held is not None else None
    latents = sample_windows(L, c.seq_len, c.seed_frames, bundle.neutral_seed(c.seed_frames), sample,
                             seed, crossfade=False, progress=progress, held=held)
    return latents, None if held is not None else bundle.decode(latents, num_frames)


LONG_AUDIO_NOTE = ("authors' model run with our long-audio handling: 128-frame windows, neutral first seed, "
                   "any length (their code truncates at 63 s and seeds from a ground-truth file)")
