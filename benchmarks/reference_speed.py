"""Our reference implementation vs the authors' code, same weights, same function, side by side in one run.

    PYTHONPATH=<deps with einops, omegaconf, diffusers> .venv/bin/python benchmarks/reference_speed.py \
        --reference-code /path/to/GestureLSM@fe124e0 [--repeats 5] [--threads 1]

Paper-size models with random weights (the released files are not needed for timing): the authors'
GestureLSM / GestureMF classes built from their configs_new/*.yaml, their state dict converted into ours,
outputs checked equal first (max abs difference <= 1e-4, or the script stops). Timed (median of interleaved repeats):
one denoiser step with the CFG pair for a 128-frame window, and one clip (speech encoder + sampler) for shortcut 2 / 8
steps (CFG 2) and MeanFlow 1 step; then our real-time factor for 60 s of synthetic speech (features, all windows, RVQ
decoding at paper size, 6D -> axis-angle). Without --reference-code only our side is measured.
"""
from __future__ import annotations

from _harness import set_threads, timed

import argparse
import os
import pickle
import statistics
import sys
import tempfile
import types

import numpy as np
import torch


def _timed(fn, repeats: int) -> float:
    return timed(fn, repeats).median


def _check_equal(diff: float, what: str, tol: float = 1e-4) -> None:
    """Timing two different functions would mean nothing: stop if ours and theirs disagree."""
    if not diff <= tol:
        raise SystemExit(f"{what}: ours and theirs differ by {diff:.2e} (> {tol:g}); not timing different functions")


def _their_model(code: str, kind: str, vocab_dir: str):
    sys.path.insert(0, code)
    cwd = os.getcwd()
    os.chdir(code)
    try:
        from omegaconf import OmegaConf
        mod = __import__(f"models.{ {'shortcut': 'LSM', 'meanflow': 'MeanFlow'}[kind] }", fromlist=["x"])
        cfg = OmegaConf.load(f"configs_new/{kind}_rvqvae_128.yaml")
        cfg.model.modality_encoder.params.data_path = vocab_dir + "/"
        return getattr(mod, {"shortcut": "GestureLSM", "meanflow": "GestureMF"}[kind])(cfg).eval()
    finally:
        os.chdir(cwd)


def compare(code: str, repeats: int) -> list[tuple[str, float, float]]:
    from gesturelsm.reference.convert import generator_from_state
    from gesturelsm.reference.samplers import _velocity, guided_kv

    vdir = tempfile.mkdtemp()
    os.makedirs(f"{vdir}/weights")
    with open(f"{vdir}/weights/vocab.pkl", "wb") as f:  # their encoder reads only the embedding's shape from it
        pickle.dump(types.SimpleNamespace(word_embedding_weights=np.zeros((11195, 300), np.float32)), f)
    rows = []
    audio = torch.rand(1, 533 * 128, 2)
    words = torch.randint(0, 11195, (1, 128))
    seed = torch.randn(1, 4, 384)
    for kind, steps_list in (("shortcut", (2, 8)), ("meanflow", (1,))):
        torch.manual_seed(0)
        theirs = _their_model(code, kind, vdir)
        ours = generator_from_state(theirs.state_dict(), kind)
        cond = {"y": {"audio_onset": audio, "word": words, "id": None, "seed": seed, "style_feature": None}}
        with torch.no_grad():
            at = theirs.modality_encoder(audio, words)
            x, t, d = torch.randn(1, 384, 1, 32), torch.tensor([0.4]), torch.tensor([0.5])
            scale = 2.0 if kind == "shortcut" else 1.0
            ref_step = lambda: theirs.apply_classifier_free_guidance(x, t, seed, at, d, scale)  # noqa: E731
            kv = guided_kv(ours.denoiser, ours.speech(audio, words), scale)
            f = _velocity(ours.denoiser, kv, seed, scale)
            our_step = lambda: f(x[:, :, 0], t, d)  # noqa: E731
            diff = (ref_step()[:, :, 0] - our_step()).abs().max().item()
            print(f"{kind}: one guided step, max |ours - theirs| = {diff:.2e}")
            _check_equal(diff, f"{kind} guided step")
            if kind == "shortcut":
                ta, tb = [], []
                for _ in range(repeats):  # interleaved
                    ta.append(_timed(ref_step, 1))
                    tb.append(_timed(our_step, 1))
                rows.append(("denoiser step, CFG pair, 128 frames", statistics.median(ta), statistics.median(tb)))
            for n in steps_list:
                theirs.num_inference_steps = n
                torch.manual_seed(1)
                ref_out = theirs(cond)
                our_out = ours.sample(audio, words, seed, ref_out["init_noise"][:, :, 0], steps=n,
                                      cfg_scale=theirs.guidance_scale)
                diff = (ref_out['latents'][:, :, 0] - our_out).abs().max().item()
                print(f"{kind} {n} steps: clip max |ours - theirs| = {diff:.2e}")
                _check_equal(diff, f"{kind} {n}-step clip")
                noise = ref_out["init_noise"][:, :, 0]
                ta, tb = [], []
                for _ in range(repeats):
                    ta.append(_timed(lambda: theirs(cond), 1))
                    tb.append(_timed(lambda: ours.sample(audio, words, seed, noise, steps=n,
                                                         cfg_scale=theirs.guidance_scale), 1))
                rows.append((f"clip: {kind} {n} step(s), CFG {theirs.guidance_scale:g}", statistics.median(ta),
                             statistics.median(tb)))
    return rows


def real_time_factor(seconds: float, repeats: int) -> list[tuple[str, float]]:
    from gesturelsm.reference.config import GeneratorConfig, PAPER_RVQ
    from gesturelsm.reference.model import ReferenceGenerator
    from gesturelsm.reference.runner import ReferenceBundle, generate_reference
    from gesturelsm.reference.rvq import ReferenceRVQ

    torch.manual_seed(0)
    rvqs = {r: ReferenceRVQ(c).eval() for r, c in PAPER_RVQ.items()}
    for m in rvqs.values():
        m.codes.normal_()
    stats = {"mean": torch.zeros(330), "std": torch.ones(330), "trans_mean": torch.zeros(3), "trans_std": torch.ones(3)}
    bundle = ReferenceBundle(rvqs, stats)
    t = np.arange(int(seconds * 16000)) / 16000
    y = (0.3 * np.clip(np.sin(2 * np.pi * 3.1 * t), 0, None) ** 2 * np.sin(2 * np.pi * 180 * t)).astype(np.float32)
    out = []
    for method, steps, scale in (("meanflow", 1, 1.0), ("shortcut", 2, 2.0), ("shortcut", 8, 2.0)):
        g = ReferenceGenerator(GeneratorConfig(method=method, steps=steps, cfg_scale=scale)).eval()
        s = _timed(lambda: generate_reference(bundle, g, {}, y, int(seconds * 30), None, steps, scale, 0), repeats)
        out.append((f"{method} {steps} step(s), CFG {scale:g}", seconds / s))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reference-code", help="checkout of the authors' GestureLSM at fe124e0 (optional)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    set_threads(args.threads)
    print(f"torch {torch.__version__}, {args.threads} thread(s), median of {args.repeats}")
    if args.reference_code:
        rows = compare(args.reference_code, args.repeats)
        print("\n| what | theirs (s) | ours (s) | ours faster |\n|---|---|---|---|")
        for name, a, b in rows:
            print(f"| {name} | {a:.4f} | {b:.4f} | {a / b:.2f}x |")
    print(f"\n| ours, {args.seconds:g} s of speech, paper-size models | real-time factor |\n|---|---|")
    for name, rtf in real_time_factor(args.seconds, max(1, args.repeats // 2)):
        print(f"| {name} | {rtf:.2f} |")


if __name__ == "__main__":
    main()
