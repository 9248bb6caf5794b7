"""fp32 GFLOP/s of PyTorch's default kernels against oneDNN's, for the products the authors' paper-size model runs
(one CFG pair, 128-frame window) and its speech encoder's convolutions: part 3 of kernels_speed.py,

    .venv/bin/python benchmarks/kernels_speed.py --products [--threads 1]

Linear: F.linear (MKL sgemm) vs kernels.linear with oneDNN forced (GESTURELSM_KERNELS=all). Convolution: F.conv1d
vs kernels.conv1d_as_2d (channels-last). Also prints the largest difference from a float64 product, so the speed is
not bought with precision. Medians of interleaved repeats, timed as the kernels' own choices are
(kernels.choice.compare: this thread's CPU time at one thread, wall time otherwise).
"""
from __future__ import annotations

from _harness import set_threads

import contextlib
import os

import torch
import torch.nn.functional as F

from gesturelsm.evaluation.timing import hardware_name
from gesturelsm.kernels import channels_last_1d, conv1d_as_2d, linear, onednn_linear_available
from gesturelsm.kernels.choice import compare

# (rows, in, out): cross-attention MLP at width 768 (B 2 x 32 tokens); spatial-temporal blocks at width 256
LINEARS = [(64, 768, 3072), (64, 3072, 768), (192, 256, 1024), (192, 1024, 256), (192, 256, 768)]
# (channels in, out, length, stride, padding): the speech encoder's largest convolutions (kernel 15)
CONVS = [(64, 64, 14322, 1, 7), (64, 64, 14322, 6, 0), (128, 128, 396, 1, 7)]


@contextlib.contextmanager
def env(values: dict[str, str]):
    """These environment variables set while the block runs, restored after."""
    old = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in old.items():
            os.environ.pop(k, None) if v is None else os.environ.__setitem__(k, v)


def products_table(threads: int, repeats: int = 9) -> None:
    """Print the table (oneDNN forced for kernels.linear while it runs)."""
    set_threads(threads)
    with env({"GESTURELSM_KERNELS": "all"}):
        _table(threads, repeats)


def _table(threads: int, repeats: int) -> None:
    print(f"\ntorch {torch.__version__}, {hardware_name('cpu')}, {threads} thread(s), "
          f"oneDNN linear available: {onednn_linear_available()}\n")
    print("| product | default GFLOP/s | oneDNN GFLOP/s | faster | max rel. error default / oneDNN |")
    print("|---|---|---|---|---|")
    g = torch.Generator().manual_seed(0)
    with torch.no_grad():
        for m, k, n in LINEARS:
            x, w, b = torch.randn(m, k, generator=g), torch.randn(n, k, generator=g), torch.randn(n, generator=g)
            exact = F.linear(x.double(), w.double(), b.double())
            err = [((y.double() - exact).abs().max() / exact.abs().max()).item()
                   for y in (F.linear(x, w, b), linear(x, w, b))]
            ta, tb, _ = compare(lambda: F.linear(x, w, b), lambda: linear(x, w, b), repeats)
            fl = 2 * m * k * n / 1e9
            print(f"| linear {m}x{k} -> {n} | {fl / ta:.0f} | {fl / tb:.0f} | {ta / tb:.2f}x "
                  f"| {err[0]:.1e} / {err[1]:.1e} |")
        for ci, co, length, stride, pad in CONVS:
            x, w, b = torch.randn(1, ci, length, generator=g), torch.randn(co, ci, 15, generator=g), torch.randn(co)
            x2, w2 = channels_last_1d(x), w[:, :, None].contiguous(memory_format=torch.channels_last)
            exact = F.conv1d(x.double(), w.double(), b.double(), stride, pad)
            err = [((y.double() - exact).abs().max() / exact.abs().max()).item()
                   for y in (F.conv1d(x, w, b, stride, pad), conv1d_as_2d(x2, w2, b, stride, pad)[:, :, 0])]
            ta, tb, _ = compare(lambda: F.conv1d(x, w, b, stride, pad), lambda: conv1d_as_2d(x2, w2, b, stride, pad),
                             repeats)
            fl = 2 * exact.shape[-1] * co * ci * 15 / 1e9
            print(f"| conv k15 {ci} -> {co}, length {length}, stride {stride} | {fl / ta:.0f} | {fl / tb:.0f} | "
                  f"{ta / tb:.2f}x | {err[0]:.1e} / {err[1]:.1e} |")

