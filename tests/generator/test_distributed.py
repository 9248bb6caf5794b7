"""Process layout of `gesturelsm train` under torchrun, decided on a CPU with faked GPU counts."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from gesturelsm.generator import distributed
from gesturelsm.generator.distributed import LaunchError, check_launch, plan_from_env, plan_processes

REPO = Path(__file__).resolve().parents[2]


def torchrun_env(world: int, rank: int, local_world: int | None = None) -> dict[str, str]:
    """What torchrun sets for process `rank` of `world`, `local_world` processes per node (default: one node)."""
    local_world = local_world or world
    return {"WORLD_SIZE": str(world), "RANK": str(rank), "LOCAL_RANK": str(rank % local_world),
            "LOCAL_WORLD_SIZE": str(local_world)}


@pytest.mark.parametrize("cuda_count", [0, 1, 8])
def test_backend_follows_the_device_option_not_the_hardware(cuda_count):
    plan = plan_processes(2, 1, 1, 2, "cpu", cuda_count)
    assert (plan.backend, plan.device) == ("gloo", "cpu")          # a GPU machine with --device cpu: still gloo
    if cuda_count >= 2:
        plan = plan_processes(2, 1, 1, 2, "cuda", cuda_count)
        assert (plan.backend, plan.device) == ("nccl", "cuda:1")


def test_auto_picks_cuda_only_when_a_gpu_is_visible():
    assert plan_processes(4, 3, 3, 4, "auto", 0).backend == "gloo"      # CUDA_VISIBLE_DEVICES= -> gloo
    assert plan_processes(4, 3, 3, 4, "auto", 4).device == "cuda:3"
    assert plan_processes(1, 0, 0, 1, "auto", 0) == distributed.ProcessPlan(1, 0, 0, 1, "cpu", None)
    assert plan_processes(1, 0, 0, 1, "auto", 2).device == "cuda"


def test_each_process_owns_the_gpu_of_its_local_rank_on_several_nodes():
    # 2 nodes x 4 GPUs: global ranks 4..7 live on node 1 and use its GPUs 0..3
    devices = [plan_from_env("cuda", torchrun_env(8, r, 4), lambda: 4).device for r in range(8)]
    assert devices == [f"cuda:{i}" for i in (0, 1, 2, 3, 0, 1, 2, 3)]
    assert {plan_from_env("cuda", torchrun_env(8, r, 4), lambda: 4).backend for r in range(8)} == {"nccl"}


@pytest.mark.parametrize("procs,gpus", [(2, 1), (3, 2), (8, 4)])
def test_more_processes_than_gpus_is_refused_with_what_to_do(procs, gpus):
    for rank in range(procs):
        with pytest.raises(LaunchError) as err:
            plan_processes(procs, rank, rank, procs, "cuda", gpus)
        msg = str(err.value)
        assert "one process per GPU" in msg and f"--nproc_per_node {gpus}" in msg and "\n" not in msg


def test_other_refusals():
    with pytest.raises(LaunchError, match="no CUDA GPU is visible"):
        plan_processes(1, 0, 0, 1, "cuda", 0)
    with pytest.raises(LaunchError, match="names one GPU"):
        plan_processes(2, 0, 0, 2, "cuda:0", 2)                    # every process on the same GPU
    with pytest.raises(LaunchError, match="2 visible CUDA GPU"):
        plan_processes(1, 0, 0, 1, "cuda:2", 2)
    with pytest.raises(LaunchError, match="not a whole number"):
        plan_from_env("cpu", {"WORLD_SIZE": "two"}, lambda: 0)
    with pytest.raises(LaunchError, match="not a device"):
        plan_processes(1, 0, 0, 1, "gpu", 0)
    assert plan_processes(1, 0, 0, 1, "cuda:1", 2).device == "cuda:1"


def test_no_torchrun_environment_is_one_process():
    plan = plan_from_env("cpu", {}, lambda: 0)
    assert not plan.distributed and plan.backend is None and plan.device == "cpu"


def test_only_the_first_process_of_a_node_prints_the_refusal():
    with pytest.raises(LaunchError):
        check_launch("cuda", torchrun_env(2, 0), lambda: 1)
    with pytest.raises(SystemExit) as out:                         # rank 1 exits 2 without a second message
        check_launch("cuda", torchrun_env(2, 1), lambda: 1)
    assert out.value.code == 2


@pytest.mark.slow                       # a new interpreter per rank: the full tier
@pytest.mark.parametrize("rank,lines", [(0, 1), (1, 0)])
def test_train_command_refuses_before_loading_anything(tmp_path, rank, lines):
    """`gesturelsm train` as process `rank` of 2 torchrun processes on a (faked) one-GPU machine: exit status 2
    and one line (from the first process only), before the data folder is even looked at (it does not exist)."""
    code = ("import sys, torch\n"
            "torch.cuda.device_count = lambda: 1\n"
            "from gesturelsm.cli import main\n"
            f"sys.exit(main(['train', '--data', {str(tmp_path / 'missing')!r}, '--device', 'cuda']))\n")
    env = dict(os.environ, PYTHONPATH=str(REPO), **torchrun_env(2, rank))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 2
    err = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(err) == lines, proc.stderr
    if lines:
        assert err[0].startswith("gesturelsm train: error: 2 training processes on this node but 1 visible CUDA")
    assert "missing" not in proc.stderr and "Traceback" not in proc.stderr
