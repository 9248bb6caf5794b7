"""Generative methods behind one interface (see base.py): GestureLSM's shortcut flow matching and the
baselines it is compared with, on the same backbone. Convention: t = 0 noise, t = 1 data.

The registry: `METHODS` maps each method's key to its class; the maths facts of a method (its most steps, what its
sampler asks the network for, whether it takes a step size) are its class's `facts`, declared without torch in
facts.py (`FACTS`, in the same order), so the command line and the backend registry read them before any model code
loads. A new method = a new module in this folder, its facts in facts.py and one line in `_classes` below, and its
spec line (label, default steps ...) in the backend registry (`gesturelsm.backends`), which serves it.
`windows.py` is the long-audio window loop every backend's sampling runs in.
The other names are imported from their modules on first use (torch loads then).
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .facts import FACTS, MethodFacts, method_facts

_HOME = {
    "LossResult": "base", "Method": "base", "ModelFn": "base", "euler_sample": "base", "guided": "base",
    "DDIM": "ddim", "RectifiedFlow": "rectified", "Shortcut": "shortcut", "sample_t": "timesteps",
    "Held": "windows", "sample_windows": "windows", "sampled_windows": "windows", "window_layout": "windows",
}

if TYPE_CHECKING:
    from .base import LossResult, Method, ModelFn, euler_sample, guided
    from .ddim import DDIM
    from .rectified import RectifiedFlow
    from .shortcut import Shortcut
    from .timesteps import sample_t
    from .windows import Held, sample_windows, sampled_windows, window_layout

    METHODS: dict[str, type[Method]]


def _classes() -> dict[str, type[Method]]:
    """{method key: its class}, in the order of `FACTS`."""
    from .ddim import DDIM
    from .rectified import RectifiedFlow
    from .shortcut import Shortcut

    return {m.facts.key: m for m in (Shortcut, RectifiedFlow, DDIM)}


def __getattr__(name: str) -> Any:
    if name == "METHODS":
        value: Any = _classes()
    elif name in _HOME:
        value = getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def _methods() -> dict[str, type[Method]]:
    return globals().get("METHODS") or __getattr__("METHODS")


def make_method(name: str, **kwargs) -> Method:
    return _methods()[method_facts(name).key](**kwargs)


def training_method(name: str, prediction: str = "data", time_sampler: str = "beta") -> Method:
    """The method `name` configured as `gesturelsm train` trains it."""
    return _methods()[method_facts(name).key].for_training(prediction, time_sampler)


__all__ = ["LossResult", "Method", "MethodFacts", "ModelFn", "euler_sample", "guided", "DDIM", "RectifiedFlow",
           "Shortcut", "sample_t", "METHODS", "FACTS", "method_facts", "make_method",
           "training_method", "Held", "sample_windows", "sampled_windows", "window_layout"]
