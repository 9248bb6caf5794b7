"""GPU-correct timing and hardware names, checked on a CPU with fake device hooks."""
import pytest
import torch

from gesturelsm.evaluation import timing
from gesturelsm.evaluation.timing import check_device, cpu_model, hardware_name, timed


def test_timed_synchronises_before_starting_and_before_stopping_the_clock():
    log: list[str] = []

    def clock() -> float:
        log.append("clock")
        return float(len(log))

    out, seconds = timed(lambda: log.append("fn") or 7, "cuda:0", sync=lambda d: log.append(f"sync {d}"), clock=clock)
    # queued work finishes before the clock starts; this call's work finishes before it stops
    assert log == ["sync cuda:0", "clock", "fn", "sync cuda:0", "clock"]
    assert out == 7 and seconds == 5.0 - 2.0


def test_default_hook_waits_for_cuda_and_not_for_the_cpu(monkeypatch):
    calls = []
    monkeypatch.setattr(torch.cuda, "synchronize", lambda device=None: calls.append(device))
    timed(lambda: None, "cpu")
    assert calls == []
    timed(lambda: None, "cuda:1")
    assert calls == [torch.device("cuda:1")] * 2


def test_ms_per_step_is_timed_with_synchronisation(monkeypatch):
    from gesturelsm.evaluation.bench import ms_per_step
    from gesturelsm.generator.config import PRESETS
    from gesturelsm.generator.model import GestureGenerator

    calls = []
    monkeypatch.setattr(timing, "synchronize", lambda d: calls.append(d))
    torch.manual_seed(0)
    ms = ms_per_step(GestureGenerator(PRESETS["tiny"]).eval(), repeats=3)
    assert ms > 0 and calls == [torch.device("cpu")] * 6        # two per timed call


def test_hardware_names(monkeypatch, tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel name\t: AMD EPYC 7B13 64-Core Processor\n")
    assert hardware_name("cpu", info) == "cpu: AMD EPYC 7B13 64-Core Processor"
    assert cpu_model(tmp_path / "absent")                         # falls back to what platform knows
    monkeypatch.setattr(torch.cuda, "get_device_name", lambda device=None: f"NVIDIA H100 80GB HBM3 ({device})")
    assert hardware_name("cuda:0") == "NVIDIA H100 80GB HBM3 (cuda:0)"


def test_check_device(monkeypatch):
    assert check_device("cpu") == torch.device("cpu")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(ValueError, match="no CUDA GPU is visible"):
        check_device("cuda")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 2)
    assert check_device("cuda:1") == torch.device("cuda:1")
    with pytest.raises(ValueError, match="2 visible CUDA GPU"):
        check_device("cuda:2")
    with pytest.raises(ValueError, match="not a device"):
        check_device("gpu0")


def test_bench_refuses_a_missing_gpu_in_one_line(monkeypatch, tmp_path, capsys):
    from gesturelsm.cli import main

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert main(["bench", "--device", "cuda", "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["gesturelsm bench: error: --device cuda: no CUDA GPU is visible (CUDA build of torch installed? "
                   "CUDA_VISIBLE_DEVICES?)"]
    assert not (tmp_path / "b").exists()                          # refused before anything ran
