"""How one training process runs: alone, or as one of several started by `torchrun` (DistributedDataParallel).

The decision is a pure function of what torchrun put in the environment (WORLD_SIZE, RANK, LOCAL_RANK,
LOCAL_WORLD_SIZE), the `--device` option and the number of visible CUDA GPUs, so it is tested on a CPU:

- the process-group backend follows `--device`: gloo for CPU processes, nccl for CUDA ones (never "nccl
  because a GPU happens to be present": `--device cpu` on a GPU machine trains on the CPUs with gloo);
- CUDA training needs one process per GPU: process LOCAL_RANK uses GPU LOCAL_RANK. More processes on a node
  than visible GPUs, or one named GPU (`cuda:1`) for several processes, is refused with one clear line before
  any data is loaded (NCCL would otherwise fail later with "Duplicate GPU detected").
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable, Mapping

import torch

from ..errors import UserError


class LaunchError(UserError):
    """The processes cannot train as started (e.g. more processes than GPUs); the message says what to change
    (the command line prints it as one line and exits with status 2)."""


@dataclass(frozen=True)
class ProcessPlan:
    world_size: int          # processes in the whole job (all nodes)
    rank: int                # this process among them (0 writes checkpoints and logs)
    local_rank: int          # this process on its node (= its GPU index with CUDA)
    local_world_size: int    # processes on this node
    device: str              # "cpu", "cuda" (single process) or "cuda:<local_rank>"
    backend: str | None      # "gloo" | "nccl"; None for a single process (no process group)

    @property
    def distributed(self) -> bool:
        return self.world_size > 1


def _env_int(env: Mapping[str, str], key: str, default: int) -> int:
    raw = env.get(key, "")
    if raw.strip() == "":
        return default
    try:
        return int(raw)
    except ValueError:
        raise LaunchError(f"environment variable {key}={raw!r} is not a whole number (set by torchrun)") from None


def plan_processes(world_size: int, rank: int, local_rank: int, local_world_size: int, device: str,
                   cuda_count: int) -> ProcessPlan:
    """Where this process trains and with which backend. `device`: auto | cpu | cuda | cuda:N (the `--device`
    option); `cuda_count`: visible CUDA GPUs on this node. Raises LaunchError when the job cannot run."""
    if world_size < 1 or not 0 <= rank < world_size:
        raise LaunchError(f"invalid process layout: rank {rank} of {world_size} processes")
    if not 0 <= local_rank < max(local_world_size, 1):
        raise LaunchError(f"invalid process layout: local rank {local_rank} of {local_world_size} on this node")
    dev = device.strip().lower()
    if dev == "auto":
        dev = "cuda" if cuda_count > 0 else "cpu"
    kind, _, index = dev.partition(":")
    if kind == "cuda" and cuda_count == 0:
        raise LaunchError(f"--device {device}: no CUDA GPU is visible (install the CUDA build of torch, check "
                          "CUDA_VISIBLE_DEVICES), or use --device cpu")
    if kind == "cuda" and index and (not index.isdigit() or int(index) >= cuda_count):
        raise LaunchError(f"--device {device}: this machine has {cuda_count} visible CUDA GPU(s) "
                          f"(cuda:0 .. cuda:{cuda_count - 1})")
    if world_size == 1:
        try:
            torch.device(dev)
        except RuntimeError:
            raise LaunchError(f"--device {device}: not a device (use cpu, cuda, cuda:N or auto)") from None
        return ProcessPlan(1, 0, 0, 1, dev, None)
    if kind == "cpu":
        return ProcessPlan(world_size, rank, local_rank, local_world_size, "cpu", "gloo")
    if kind != "cuda":
        raise LaunchError(f"--device {device}: several processes train on cpu (gloo) or cuda (nccl) only")
    if index:
        raise LaunchError(f"--device {device} names one GPU, but {world_size} processes were started; use "
                          "--device cuda (process LOCAL_RANK trains on GPU LOCAL_RANK)")
    if local_world_size > cuda_count or local_rank >= cuda_count:
        raise LaunchError(f"{local_world_size} training processes on this node but {cuda_count} visible CUDA "
                          f"GPU(s): one process per GPU is required; start torchrun with --nproc_per_node "
                          f"{cuda_count} or fewer, or use --device cpu for CPU processes (gloo)")
    return ProcessPlan(world_size, rank, local_rank, local_world_size, f"cuda:{local_rank}", "nccl")


def plan_from_env(device: str, env: Mapping[str, str] | None = None,
                  cuda_count: Callable[[], int] | None = None) -> ProcessPlan:
    """plan_processes for this process, read from torchrun's environment variables (none: a single process).
    `cuda_count`: how to count visible GPUs (default torch.cuda.device_count, looked up at call time)."""
    env = os.environ if env is None else env
    cuda_count = cuda_count or torch.cuda.device_count
    world = _env_int(env, "WORLD_SIZE", 1)
    local_rank = _env_int(env, "LOCAL_RANK", 0)
    local_world = _env_int(env, "LOCAL_WORLD_SIZE", world if "LOCAL_RANK" in env else 1)
    return plan_processes(world, _env_int(env, "RANK", 0), local_rank, local_world, device, cuda_count())


def check_launch(device: str, env: Mapping[str, str] | None = None,
                 cuda_count: Callable[[], int] | None = None) -> ProcessPlan:
    """plan_from_env, meant to run before anything is loaded. On a refusal the first process of each node
    raises LaunchError (one printed line, exit status 2); the others exit with status 2 silently, so a
    torchrun job says it once per node rather than once per process."""
    env = os.environ if env is None else env
    try:
        return plan_from_env(device, env, cuda_count)
    except LaunchError:
        if _env_int(env, "LOCAL_RANK", 0) != 0:
            raise SystemExit(2) from None
        raise


def setup_processes(device: str) -> tuple[int, int, torch.device]:
    """Check the launch, start the process group when several processes run (backend from `device`, see
    plan_processes) and pin CUDA processes to their GPU. -> (rank, world size, this process's device)."""
    import torch.distributed as dist

    plan = check_launch(device)
    if dist.is_initialized():                           # a caller started the group: keep its layout
        return dist.get_rank(), dist.get_world_size(), torch.device(plan.device)
    if plan.distributed:
        if plan.backend == "nccl":
            torch.cuda.set_device(plan.local_rank)      # before NCCL starts: each process owns its GPU
        dist.init_process_group(plan.backend)
    return plan.rank, plan.world_size, torch.device(plan.device)
