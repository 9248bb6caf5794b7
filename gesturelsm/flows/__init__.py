"""Generative methods behind one interface (see base.py): GestureLSM's shortcut flow matching and the
baselines it is compared with, on the same backbone. Convention: t = 0 noise, t = 1 data.

The registry: `METHODS` maps each method's key to its class; the maths facts of a method (its most steps, what its
sampler asks the network for, whether it takes a step size) are its class's `facts`. A new method = a new module in
this folder + one line below, and its spec line (label, default steps ...) in the backend registry
(`gesturelsm.backends`), which serves it.
`windows.py` is the long-audio window loop every backend's sampling runs in.
"""
from ..errors import InputError
from .base import LossResult, Method, MethodFacts, ModelFn, euler_sample, guided
from .ddim import DDIM
from .rectified import RectifiedFlow
from .shortcut import Shortcut
from .timesteps import sample_t
from .windows import Held, sample_windows, sampled_windows, window_layout

METHODS: dict[str, type] = {m.facts.key: m for m in (
    Shortcut, RectifiedFlow, DDIM,
)}
FACTS: dict[str, MethodFacts] = {k: m.facts for k, m in METHODS.items()}


def method_facts(name: str) -> MethodFacts:
    if name not in FACTS:
        raise InputError(f"unknown method {name!r}; choose from {', '.join(FACTS)}")
    return FACTS[name]


def make_method(name: str, **kwargs) -> Method:
    return METHODS[method_facts(name).key](**kwargs)


def training_method(name: str, prediction: str = "data", time_sampler: str = "beta") -> Method:
    """The method `name` configured as `gesturelsm train` trains it."""
    return METHODS[method_facts(name).key].for_training(prediction, time_sampler)


__all__ = ["LossResult", "Method", "MethodFacts", "ModelFn", "euler_sample", "guided", "DDIM", "RectifiedFlow",
           "Shortcut", "sample_t", "METHODS", "FACTS", "method_facts", "make_method",
           "training_method", "Held", "sample_windows", "sampled_windows", "window_layout"]
