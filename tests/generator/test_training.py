import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from gesturelsm.generator.data import build_take
from gesturelsm.generator.model import GestureGenerator
from gesturelsm.generator.sampling import generate_latents
from gesturelsm.generator.train import GenTrainConfig, train_generator
from gesturelsm.motion import REGIONS, Normalizer
from gesturelsm.motion.regions import GENERATED_REGIONS
from gesturelsm.tokenizer import RVQVAE, preset

REPO = Path(__file__).resolve().parents[2]


def tiny_tokenizers(feats: torch.Tensor) -> dict[str, RVQVAE]:
    torch.manual_seed(0)
    toks = {}
    for r in GENERATED_REGIONS:
        cols = list(REGIONS[r].columns)
        m = RVQVAE(preset("tiny", len(cols)), r, Normalizer.fit(feats[:, cols]))
        m.train()
        m(m.normalizer.normalize(feats[: feats.shape[0] // 4 * 4, cols])[None])
        toks[r] = m.eval()
    return toks


def test_tiny_model_overfits_one_real_clip(real_motion, beat2_root):
    """Trained on one 32-frame window of real motion with its speech, the generator reproduces that
    window's latents from noise far better than it did untrained."""
    from gesturelsm.audio import load_audio

    feats = real_motion.to_features()[600:632]
    audio = load_audio(beat2_root / "wave16k" / "2_scott_0_1_1.wav")[600 * 16000 // 30:]
    toks = tiny_tokenizers(real_motion.to_features()[:640])
    take = build_take("clip", feats, audio, None, toks, None)
    tc = GenTrainConfig(method="gesturelsm", preset="tiny", steps=300, batch_size=8, lr=3e-3, warmup=10,
                        cond_drop=0.0, text_drop=0.0, neutral_seed_p=0.0, ema=0.9, eval_every=10_000,
                        save_every=10_000)
    torch.manual_seed(0)

    def error(model: GestureGenerator) -> float:
        lat = generate_latents(model, take.audio, take.words, take.has_word, False, 32, steps=4, cfg_scale=1.0)
        return ((lat - take.latents).pow(2).mean() / take.latents.var()).item()

    from dataclasses import replace

    from gesturelsm.generator.config import PRESETS

    out = Path(os.environ.get("TMPDIR", "/tmp")) / f"overfit-{os.getpid()}.safetensors"
    cfg = replace(PRESETS["tiny"], dim=64, heads=4, st_layers=2, ffn=128)
    model = train_generator([take], [], toks, tc, out, config=cfg, log=lambda *_: None)
    out.unlink(missing_ok=True)
    out.with_suffix(".state.pt").unlink(missing_ok=True)
    untrained = GestureGenerator(model.config, "gesturelsm")
    untrained.latent_std.copy_(model.latent_std)
    untrained.neutral_seed.copy_(model.neutral_seed)
    err_untrained, err_trained = error(untrained.eval()), error(model)
    assert err_trained < 0.2 and err_trained < 0.25 * err_untrained, (err_trained, err_untrained)
    # the exported (EMA) network carries the BatchNorm statistics of training, not the initial 0 / 1
    bn = [m for m in model.speech.modules() if isinstance(m, torch.nn.BatchNorm1d)]
    assert bn and all(m.num_batches_tracked == tc.steps for m in bn)
    assert min((m.running_var - 1).abs().max().item() for m in bn) > 1e-3


def test_train_cli_resumes_and_ships(tmp_path, beat2_maker, capsys):
    from gesturelsm.cli import main

    data = tmp_path / "beat2"
    beat2_maker(data, "2_scott_0_1_1", 300)
    from gesturelsm.motion import MotionSequence

    seq = MotionSequence.load(data / "smplxflame_30" / "2_scott_0_1_1.npz")
    toks = tiny_tokenizers(seq.to_features())
    for r, m in toks.items():
        m.save(tmp_path / "tok" / f"{r}.safetensors")
    def args(steps: int) -> list[str]:
        return ["train", "--data", str(data), "--tokenizers", str(tmp_path / "tok"), "--method", "rectified_flow",
                "--preset", "tiny", "--steps", str(steps), "--batch-size", "2", "--out", str(tmp_path / "run"),
                "--eval-every", "3", "--train-fraction", "0.6", "--no-text"]

    assert main(args(3) + ["--ship", str(tmp_path / "ship")]) == 0
    shipped = GestureGenerator.load(tmp_path / "ship" / "rectified_flow.safetensors")
    assert shipped.method == "rectified_flow" and not shipped.config.uses_step_size
    capsys.readouterr()
    assert main(args(5)) == 0
    assert "resumed rectified_flow.safetensors at step 3" in capsys.readouterr().out
    assert main(["train", "--data", str(data), "--tokenizers", str(tmp_path / "none")]) == 2


@pytest.mark.slow
def test_distributed_training_with_two_cpu_processes(tmp_path, beat2_maker):
    """torchrun with 2 gloo processes trains and writes one checkpoint (rank 0)."""
    data = tmp_path / "beat2"
    beat2_maker(data, "2_scott_0_1_1", 300)
    from gesturelsm.motion import MotionSequence

    seq = MotionSequence.load(data / "smplxflame_30" / "2_scott_0_1_1.npz")
    for r, m in tiny_tokenizers(seq.to_features()).items():
        m.save(tmp_path / "tok" / f"{r}.safetensors")
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(REPO))
    cmd = [sys.executable, "-m", "torch.distributed.run", "--nproc_per_node", "2", "--master_port", "29571",
           "-m", "gesturelsm", "train", "--data", str(data), "--tokenizers", str(tmp_path / "tok"),
           "--preset", "tiny", "--steps", "3", "--batch-size", "2", "--out", str(tmp_path / "run"),
           "--eval-every", "3", "--no-text", "--device", "cpu"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=240, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    model = GestureGenerator.load(tmp_path / "run" / "gesturelsm.safetensors")
    assert model.meta["step"] == "3" or model.meta["step"] == 3


def test_ema_forgets_the_initial_weights_in_short_runs():
    from gesturelsm.generator.train import ema_decay

    assert ema_decay(0, 0.999) == 0.1 and ema_decay(10_000, 0.999) == 0.999
    w = 1.0  # share of the initial weights left in the average after n updates
    for step in range(1, 1001):
        w *= ema_decay(step, 0.999)
    assert w < 0.01
