"""Where measured kernel choices are kept between processes: one small JSON file per user.

The file holds one section per machine key: the CPU's model name and feature flags, the torch version and the
number of math threads the choices were measured at. A process reads only its own key's section, so a choice
measured on another CPU, another torch build or at another thread count is never applied (a home folder shared
between machines keeps one section per machine). Everything read is checked: an unreadable, truncated or
foreign file reads as empty, and a file that cannot be written leaves the choices in memory only. A stored choice
can only make a call slower than the best choice, never different: every path computes the default's function.

Location: `$GESTURELSM_KERNELS_CACHE` (a file path; empty: keep choices in memory only), else
`$XDG_CACHE_HOME/gesturelsm/kernels.json`, else `~/.cache/gesturelsm/kernels.json`.
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import tempfile
from functools import lru_cache
from pathlib import Path

import torch

VERSION = 1
MAX_MACHINES = 16          # sections kept in one file; the oldest written goes first


def cache_path() -> Path | None:
    """The cache file, or None when caching on disk is switched off (GESTURELSM_KERNELS_CACHE set and empty)."""
    env = os.environ.get("GESTURELSM_KERNELS_CACHE")
    if env is not None:
        return Path(env).expanduser() if env.strip() else None
    base = os.environ.get("XDG_CACHE_HOME")
    if not base:
        try:
            base = str(Path.home() / ".cache")
        except RuntimeError:                                      # no home folder to be found: memory only
            return None
    return Path(base) / "gesturelsm" / "kernels.json"


@lru_cache(maxsize=1)
def cpu_identity() -> tuple[str, str]:
    """(CPU model name, feature flags) from /proc/cpuinfo on Linux; elsewhere the platform's processor name and
    torch's widest vector instruction set."""
    name, flags = "", ""
    try:
        for line in Path("/proc/cpuinfo").read_text(errors="replace").splitlines():
            field, _, value = line.partition(":")
            field = field.strip()
            if field in ("model name", "Processor", "cpu model") and not name:
                name = value.strip()
            elif field in ("flags", "Features") and not flags:
                flags = " ".join(sorted(value.split()))
            if name and flags:
                break
    except OSError:
        pass
    return (name or platform.processor() or platform.machine(),
            flags or f"{platform.machine()} {torch.backends.cpu.get_cpu_capability()}")


def machine_key(threads: int) -> str:
    """The section name for this CPU, torch build and thread count: 'model | flags hash | torch | N threads'."""
    name, flags = cpu_identity()
    digest = hashlib.sha256(flags.encode()).hexdigest()[:16]
    return f"{name} | flags {digest} | torch {torch.__version__} | {threads} threads"


def read(path: Path | None) -> dict[str, dict[str, dict]]:
    """{machine key: {choice key: {"taken": bool, "ratio": float[, "once": s, "saving": s]}}} from the file (once:
    the fast path's one-time cost, saving: what a call saves; choice.py); {} for anything unreadable, and an entry
    that does not read as one is left out."""
    if path is None:
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(data, dict) or data.get("version") != VERSION or not isinstance(data.get("machines"), dict):
        return {}
    out: dict[str, dict[str, dict]] = {}
    for machine, choices in data["machines"].items():
        if isinstance(choices, dict):
            out[machine] = {k: v for k, v in choices.items() if _valid(v)}
    return out


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _valid(entry) -> bool:
    return (isinstance(entry, dict) and isinstance(entry.get("taken"), bool) and _number(entry.get("ratio"))
            and all(_number(entry[k]) and entry[k] >= 0 for k in ("once", "saving") if k in entry))


def write(path: Path | None, machine: str, choices: dict[str, dict]) -> None:
    """Merge `choices` into the file's section `machine` (other processes' entries kept), atomically; a failure
    to write is not an error (the choices stay in this process's memory)."""
    if path is None:
        return
    machines = read(path)
    section = machines.pop(machine, {})
    section.update(choices)
    machines[machine] = section                                   # last written last: trimmed last
    while len(machines) > MAX_MACHINES:
        machines.pop(next(iter(machines)))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".kernels-", suffix=".json", dir=path.parent)
        with os.fdopen(fd, "w") as f:
            json.dump({"version": VERSION, "machines": machines}, f, indent=1, sort_keys=True)
        os.replace(tmp, path)
    except OSError:
        try:
            os.unlink(tmp)                                        # type: ignore[possibly-undefined]
        except (OSError, NameError):
            pass
