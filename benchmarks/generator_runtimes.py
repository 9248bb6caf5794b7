"""The shipped generator's guided sampling step under other CPU inference runtimes, against PyTorch's.

    .venv/bin/python benchmarks/generator_runtimes.py [--threads 1] [--rounds 60]
    (ONNX Runtime rows need `pip install onnx` for the export; OpenVINO rows need `pip install openvino`)

Why it exists: the question "would another runtime make a step of our generator much faster on this CPU, with the
same outputs" is answered by measuring, not by reputation. Rows, all on one 128-frame window with guidance (the
conditional and null halves in one batch, as every sampler runs it):
- torch default: GestureGenerator.load(..., accelerated=False), plain modules;
- torch accelerated: what every loader hands out (kernels.accelerate: folded cross-attention, traced trunk);
- onnxruntime / openvino: the accelerated model with its trunk (cross and spatial-temporal blocks, output layer; the
  bulk of a step) exported once and run by that runtime in fp32, everything before the trunk still in torch.
Calls alternate round by round, so load from other processes hits every row alike; medians of wall time, each row's
ratio to torch default, and the largest relative difference of its output from torch default's (same inputs).
ONNX has no complex numbers: the export writes the rotary rotation in real arithmetic, the same products
(x1 cos a - x2 sin a, x1 sin a + x2 cos a), so the same values; the trunk's shapes are fixed at export.
"""
from __future__ import annotations

from _harness import set_threads

import argparse
import contextlib
import io
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
CKPT = REPO / "assets" / "generator" / "gesturelsm.safetensors"

from generator_step_speed import rel, speech  # noqa: E402  (this folder is on sys.path when run as a script)


@contextlib.contextmanager
def real_rotary():
    """Self-attention's rotary rotation in real arithmetic while exporting (restored after)."""
    from gesturelsm.generator import layers

    def apply_rotary(x: torch.Tensor, freqs: torch.Tensor) -> torch.Tensor:
        f = freqs.detach()                                   # a constant of the exported graph
        cos = f.real.repeat_interleave(2, -1).contiguous()
        sin = f.imag.repeat_interleave(2, -1).contiguous()
        swapped = torch.stack([-x[..., 1::2], x[..., 0::2]], -1).flatten(-2)
        return x * cos + swapped * sin

    def rotary_freqs(n, head_dim, device, base=1e4):        # plain ints, so the table is made once, not traced
        return old_freqs(int(n), int(head_dim), device, base)

    old = layers.apply_rotary, layers.FastSelfAttention.forward, layers.rotary_freqs
    old_freqs = layers.rotary_freqs
    layers.apply_rotary, layers.FastSelfAttention.forward = apply_rotary, layers.SelfAttention.forward
    layers.rotary_freqs = rotary_freqs
    try:
        yield
    finally:
        layers.apply_rotary, layers.FastSelfAttention.forward, layers.rotary_freqs = old


def onnx_bytes(trunk: torch.nn.Module, inputs: tuple[torch.Tensor, ...]) -> bytes:
    f = io.BytesIO()
    with real_rotary(), torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(trunk, inputs, f, dynamo=False, opset_version=17,
                          input_names=[f"in{i}" for i in range(len(inputs))], output_names=["out"])
    return f.getvalue()


def ort_runner(trunk, inputs, threads):
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.intra_op_num_threads, so.inter_op_num_threads = threads, 1
    so.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    sess = ort.InferenceSession(onnx_bytes(trunk, inputs), so, providers=["CPUExecutionProvider"])
    names = [i.name for i in sess.get_inputs()]                 # the exporter drops inputs the graph never reads
    index = {f"in{i}": i for i in range(len(inputs))}

    def run(*xs: torch.Tensor) -> torch.Tensor:
        return torch.from_numpy(sess.run(None, {n: xs[index[n]].contiguous().numpy() for n in names})[0])
    return run


def openvino_runner(trunk, inputs, threads):
    import openvino as ov

    with real_rotary(), torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = ov.convert_model(trunk, example_input=inputs)
    compiled = ov.Core().compile_model(model, "CPU", {"INFERENCE_NUM_THREADS": threads, "PERFORMANCE_HINT": "LATENCY",
                                                      "INFERENCE_PRECISION_HINT": "f32"})
    request = compiled.create_infer_request()

    def run(*xs: torch.Tensor) -> torch.Tensor:
        return torch.from_numpy(np.array(request.infer([x.contiguous().numpy() for x in xs])[0]))
    return run


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=60)
    args = ap.parse_args()
    set_threads(args.threads)
    from gesturelsm.evaluation.timing import hardware_name
    from gesturelsm.features.audio import audio_channels
    from gesturelsm.flows.base import guided
    from gesturelsm.generator import model as gm
    from gesturelsm.generator.data import samples_for

    runtimes = {"onnxruntime": ort_runner, "openvino": openvino_runner}
    models = {"torch default": gm.GestureGenerator.load(CKPT, accelerated=False),
              "torch accelerated": gm.GestureGenerator.load(CKPT)}
    skipped = []
    for name in runtimes:
        try:
            __import__({"onnxruntime": "onnx", "openvino": "openvino"}[name])
            models[name] = gm.GestureGenerator.load(CKPT)
        except ImportError as e:
            skipped.append(f"{name} ({e.name} is not installed)")
    c = models["torch default"].config
    y, source = speech(c.window_frames / 30 + 1)
    ch = torch.from_numpy(audio_channels(y))
    win = c.window_frames
    words, has_word = torch.zeros(1, win, c.text_in), torch.zeros(1, win, dtype=torch.bool)
    g = torch.Generator().manual_seed(0)
    x = torch.randn(1, c.num_regions, c.window_latents, c.latent_dim, generator=g)
    t, d = torch.full((1,), 0.25), torch.full((1,), 0.25)
    fns, setup = {}, {}
    trace = gm._trace
    with torch.no_grad():
        for name, m in models.items():
            cond = m.speech(ch[None, :, :samples_for(win)], words, has_word, torch.tensor([False]))
            f = m.bind(cond, m.neutral_seed[None])
            fns[name] = (lambda f=f: guided(f, x, t, d, 6.0))
            if name in runtimes:                                 # the trunk is built on the first call: hand it over
                gm._trace = lambda trunk, h, kv, r=runtimes[name]: r(trunk, (h, *kv), args.threads)
            start = time.perf_counter()
            try:
                fns[name]()
            finally:
                gm._trace = trace
            setup[name] = time.perf_counter() - start
        outs = {k: fn() for k, fn in fns.items()}
        wall: dict[str, list[float]] = {k: [] for k in fns}
        for _ in range(args.rounds):
            for k, fn in fns.items():
                start = time.perf_counter()
                fn()
                wall[k].append(time.perf_counter() - start)
    med = {k: 1e3 * statistics.median(v) for k, v in wall.items()}
    print(f"\n{hardware_name('cpu')}, torch {torch.__version__} ({torch.backends.cpu.get_cpu_capability()}), "
          f"{args.threads} thread(s), {args.rounds} interleaved rounds; speech: {source}")
    if skipped:
        print("not measured: " + ", ".join(skipped))
    print("\n| runtime | guided step, median ms | speed-up vs torch default | first call (export, compile) s "
          "| max rel. diff vs torch default |")
    print("|---|---|---|---|---|")
    base = med["torch default"]
    for k in fns:
        err = rel(outs[k], outs['torch default'])
        print(f"| {k} | {med[k]:.2f} | {base / med[k]:.2f}x | {setup[k]:.2f} | {err:.1e} |")


if __name__ == "__main__":
    main()
