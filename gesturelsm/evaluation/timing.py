"""Wall-clock timing that is correct on a GPU, and the name of the hardware a figure was measured on.

CUDA kernels run asynchronously: a call returns once its work is queued. `timed` therefore synchronises the
device before starting the clock (earlier queued work is not billed to this call) and again before stopping
it (this call's work is finished), instead of relying on a later copy to the CPU to wait for the GPU.
On a CPU both synchronisations are no-ops.
"""
from __future__ import annotations

import platform
import time
from pathlib import Path
from typing import Callable, TypeVar

import torch

from ..errors import UserError

T = TypeVar("T")
Sync = Callable[[torch.device], None]


def check_device(name: str) -> torch.device:
    """A `--device` value as a torch.device, or ValueError with what to use instead (one line)."""
    try:
        dev = torch.device(name)
    except RuntimeError:
        raise UserError(f"--device {name}: not a device (use cpu, cuda or cuda:N)") from None
    if dev.type == "cuda":
        count = torch.cuda.device_count() if torch.cuda.is_available() else 0
        if count == 0:
            raise UserError(f"--device {name}: no CUDA GPU is visible (CUDA build of torch installed? "
                             "CUDA_VISIBLE_DEVICES?)")
        if dev.index is not None and dev.index >= count:
            raise UserError(f"--device {name}: {count} visible CUDA GPU(s) (cuda:0 .. cuda:{count - 1})")
    elif dev.type != "cpu":
        raise UserError(f"--device {name}: timings are supported on cpu and cuda")
    return dev


def synchronize(device: str | torch.device) -> None:
    """Wait until all queued work on `device` has finished (CUDA); nothing to wait for on a CPU."""
    dev = torch.device(device)
    if dev.type == "cuda":
        torch.cuda.synchronize(dev)


def timed(fn: Callable[[], T], device: str | torch.device, sync: Sync | None = None,
          clock: Callable[[], float] = time.perf_counter) -> tuple[T, float]:
    """-> (fn(), seconds fn took on `device`), with the device synchronised before and after the call.
    `sync(device)` defaults to `synchronize`; tests pass a recorder."""
    sync = sync or synchronize
    dev = torch.device(device)
    sync(dev)
    t0 = clock()
    out = fn()
    sync(dev)
    return out, clock() - t0


def cpu_model(cpuinfo: str | Path = "/proc/cpuinfo") -> str:
    """The processor's model name (Linux /proc/cpuinfo), else what `platform` knows."""
    try:
        for line in Path(cpuinfo).read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() in ("model name", "Model", "Hardware") and value.strip():
                return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown processor"


def hardware_name(device: str | torch.device, cpuinfo: str | Path = "/proc/cpuinfo") -> str:
    """What a timing on `device` was measured on: the GPU's name for CUDA, "cpu: <model name>" otherwise."""
    dev = torch.device(device)
    if dev.type == "cuda":
        return torch.cuda.get_device_name(dev)
    return f"{dev.type}: {cpu_model(cpuinfo)}"
