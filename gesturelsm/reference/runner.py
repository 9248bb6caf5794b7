"""Run converted authors' models on any length of speech, with our long-audio handling.

Windows of 128 frames (4.27 s) advance by 112 frames; each window's seed is the last 4 latent frames of
the previous one, as in the reference. Unlike the reference (first seed taken from a ground-truth file,
trailing frames dropped, 63 s cap), the first seed is *neutral*: the RVQ encoding of the speaker's mean
pose standing still; the audio is padded to whole windows and the output cut to the speech's length.
Face: the released configs generate none, so jaw and expressions stay neutral (identity jaw, zeros).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..flows.base import MethodFacts
from ..motion.regions import join_regions
from ..motion.sequence import MotionSequence
from .config import LATENT_SCALE, REGIONS, SAMPLES_PER_FRAME
from .convert import load_generator, load_rvqs
from .model import ReferenceGenerator
from .rvq import ReferenceRVQ
from .speech import speech_features, word_tokens

# joint lists of the reference's region masks (utils/joints.py), also our regions.py order
REGION_JOINTS = {"upper": (3, 6, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21), "hands": tuple(range(25, 55)),
                 "lower": (0, 1, 2, 4, 5, 7, 8, 10, 11)}
METHOD_NAMES = {"shortcut": "gesturelsm_authors", "diffusion": "diffusion_authors", "meanflow": "meanflow_authors"}
LABELS = {"gesturelsm_authors": "GestureLSM (authors' weights)", "diffusion_authors": "Diffusion (authors' weights)",
          "meanflow_authors": "MeanFlow (authors' weights)"}
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
            m = torch.cat([m, self.stats["trans_mean"]]); s = torch.cat([s, self.stats["trans_std"]])
        return (x - m) / s

    def denormalise(self, region: str, z: torch.Tensor) -> torch.Tensor:
        m, s = self.stats["mean"][_cols(region)], self.stats["std"][_cols(region)]
        if region == "lower":
            m = torch.cat([m, self.stats["trans_mean"]]); s = torch.cat([s, self.stats["trans_std"]])
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

    def decode(self, latents: torch.Tensor, num_frames: int) -> MotionSequence:
        """(1, N, 3 * code_dim) generator latents -> motion (jaw, eyes, face neutral)."""
        parts, d = {}, self.rvqs["upper"].cfg.code_dim
        for i, r in enumerate(REGIONS):
            parts[r] = self.denormalise(r, self.rvqs[r].decode(latents[..., i * d:(i + 1) * d] * LATENT_SCALE))[0, :num_frames]
        parts["face"] = torch.zeros(num_frames, 106)
        parts["face"][:, [0, 4]] = 1.0                                 # identity 6D jaw, zero expressions
        return MotionSequence.from_features(join_regions(parts))


def load_reference_methods(root: str | Path) -> tuple[ReferenceBundle | None, dict[str, tuple[ReferenceGenerator, dict]]]:
    """Folder with reference_rvq.safetensors + reference_<method>.safetensors -> (bundle, {name: (model, vocab)})."""
    root = Path(root)
    if not (root / "reference_rvq.safetensors").exists():
        return None, {}
    rvqs, stats = load_rvqs(root / "reference_rvq.safetensors")
    gens = {}
    for method, name in METHOD_NAMES.items():
        p = root / f"reference_{method}.safetensors"
        if p.exists():
            gens[name] = load_generator(p)
    return ReferenceBundle(rvqs, stats), gens


@torch.no_grad()
def generate_reference(bundle: ReferenceBundle, model: ReferenceGenerator, word2index: dict[str, int], audio: np.ndarray,
                       num_frames: int, words: list | None, steps: int, cfg_scale: float, seed: int) -> tuple[torch.Tensor, MotionSequence]:
    """16 kHz speech -> (latents (1, N, 384), motion of num_frames frames)."""
    c = model.cfg
    W, S = c.frames, c.frames - c.seed_frames * 4                     # 128, 112
    n_win = max(1, -(-max(num_frames - W, 0) // S) + 1)
    total = W + (n_win - 1) * S
    feats = speech_features(audio)                                    # (samples, 2)
    need = total * SAMPLES_PER_FRAME
    feats = np.pad(feats, ((0, max(0, need - len(feats))), (0, 0)))[:need]
    intervals = [(w.start, w.end, w.text.lower()) for w in (words or [])]
    toks = word_tokens(intervals, total, word2index)
    gen = torch.Generator().manual_seed(int(seed))
    seed_lat = bundle.neutral_seed(c.seed_frames)
    chunks = []
    for i in range(n_win):
        a = torch.from_numpy(feats[i * S * SAMPLES_PER_FRAME:(i * S + W) * SAMPLES_PER_FRAME]).float()[None]
        w = torch.from_numpy(toks[i * S:i * S + W])[None]
        noise = torch.randn(1, c.regions * c.input_dim, c.seq_len, generator=gen)
        lat = model.sample(a, w, seed_lat, noise, steps=steps, cfg_scale=cfg_scale).transpose(1, 2)  # (1, 32, 384)
        chunks.append(lat if i == 0 else lat[:, c.seed_frames:])
        seed_lat = lat[:, -c.seed_frames:]
    latents = torch.cat(chunks, 1)
    return latents, bundle.decode(latents, num_frames)


REFERENCE_FACTS = {   # the authors' methods in the method registry's terms (flows.MethodFacts); released default steps
    "gesturelsm_authors": MethodFacts("gesturelsm_authors", LABELS["gesturelsm_authors"], 2, 128, "velocity", True,
                                      "#9467bd"),
    "meanflow_authors": MethodFacts("meanflow_authors", LABELS["meanflow_authors"], 1, 128, "velocity", True,
                                    "#8c564b"),
    "diffusion_authors": MethodFacts("diffusion_authors", LABELS["diffusion_authors"], 20, 1000, "data", False,
                                     "#e377c2", steps_setting="ddim_steps"),
}
LONG_AUDIO_NOTE = ("authors' model run with our long-audio handling: 128-frame windows, neutral first seed, "
                   "any length (their code truncates at 63 s and seeds from a ground-truth file)")


def attach_reference(pipe, root: str | Path | None) -> None:
    """Give a GesturePipeline the authors' methods found in `root` (reference_*.safetensors), if any."""
    bundle, gens = load_reference_methods(root) if root else (None, {})
    pipe.reference_bundle, pipe.reference_methods = bundle, gens


def generate_for_pipeline(pipe, speech, method: str, steps: int, cfg: float, seed: int) -> tuple[MotionSequence, dict, list]:
    """The pipeline's generate() for an authors' method: (motion, timings, warnings)."""
    import time

    model, vocab = pipe.reference_methods[method]
    t0 = time.perf_counter()
    lat, motion = generate_reference(pipe.reference_bundle, model, vocab, speech.audio, speech.num_frames,
                                     speech.words, steps, cfg, seed)
    return motion, {"sampling": time.perf_counter() - t0}, [FACE_NOTE, LONG_AUDIO_NOTE]
