"""Fast CPU paths for inference, each taken only where it is measured faster on this machine, and the module swap
that puts them into a model (`accelerate`).

The paths (choice.PATHS), each a family of kernels that computes what the default computes, up to float
summation order (no reduced precision; a GELU fused into a product is the exact erf one):
- linear: fp32 products through oneDNN instead of MKL's sgemm. MKL takes its AVX2 code on AMD CPUs, where oneDNN's
  AVX-512 kernels run the same products about twice as fast on AVX-512 parts; on Intel CPUs MKL has AVX-512 too and
  which wins depends on the shape (benchmarks/kernels_speed.py prints both).
- conv: 1D convolutions as (1 x k) 2D ones on channels-last tensors (oneDNN), faster or slower by layer and CPU.
- conv_add: a convolution summed into its residual in place by oneDNN (a residual without a new buffer).
- trace: the generator's trunk recorded once (torch.jit.trace) and replayed without the Python between its ops.
Which one is faster differs between CPUs (AMD with and without AVX-512, Intel with AVX-512 and AMX), thread counts
and shapes, so nothing is assumed: at the first call of a shape each path is timed against the default on that
call's tensors and taken only where faster by a margin (choice.py); choices are kept per CPU, torch version and
thread count in a small cache file (cache.py), so later processes measure nothing. Measuring is bounded per
process (1 s + 10 % of its running time, GESTURELSM_KERNELS_BUDGET; what has no time left is measured by a later
call or run) and says so in one line on stderr; each choice keeps the fast path's one-time cost (tracing, weight
reorders, oneDNN's kernel generation), and a process that reads it from the cache takes the path only once its calls
have paid for that cost (or at once, when the caller's `expect` says its work will), so a one-shot command does not
pay for paths it cannot use enough.

GESTURELSM_ONEDNN=0 turns every fast path off (every swapped module then computes exactly what the module it
replaced computes); GESTURELSM_KERNELS forces choices instead of measuring (`all`, `none` or a list of paths;
tests set it); GESTURELSM_KERNELS_CACHE moves the cache file (empty: memory only).

`accelerate(model)` swaps a model's modules, in place, for drop-in subclasses that take these paths: nn.Linear ->
FastLinear, LinearGELU (and nn.Linear + nn.GELU inside an nn.Sequential) -> FastLinearGELU, nn.Conv1d ->
FastConv1d, and any block whose model registered a faster version (`faster_version_of`). Same parameter tensors,
same state_dict keys; training and autograd take the default ops. The model loaders (GestureGenerator.load,
RVQVAE.load, the reference loaders) call it. `WeightsCache` keeps values derived from weights (folded BatchNorms,
the null condition's keys, traced graphs) until a weight changes.
"""
from __future__ import annotations

from .choice import PATHS, Choice, choices, decide, expect, forced, forget, probe_seconds, taken, told
from .ops import (WeightsCache, bucket, channels_last_1d, conv1d_as_2d, conv1d_as_2d_add_, conv_add_available,
                  fast_path, linear, onednn_enabled, onednn_linear_available)
from .swap import FastConv1d, FastLinear, FastLinearGELU, LinearGELU, accelerate, faster_version_of
from .trace import traced_or_eager

__all__ = ["PATHS", "Choice", "FastConv1d", "FastLinear", "FastLinearGELU", "LinearGELU", "WeightsCache",
           "accelerate", "bucket", "channels_last_1d", "choices", "conv1d_as_2d", "conv1d_as_2d_add_", "decide",
           "conv_add_available", "expect", "fast_path", "faster_version_of", "forced", "forget", "linear",
           "onednn_enabled", "onednn_linear_available", "probe_seconds", "taken", "told", "traced_or_eager"]
