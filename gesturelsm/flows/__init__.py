"""Generative methods behind one interface (see base.py): GestureLSM's shortcut flow matching and the
baselines it is compared with, on the same backbone. Convention: t = 0 noise, t = 1 data.

The registry: `METHODS` maps each method's key to its class; every fact about a method (label, default and
maximum steps, what it predicts, whether it takes a step size, plot colour) is its class's `facts`, and the
rest of the package reads them from here. A new method = a new module in this folder + one line below.
"""
from typing import Mapping

from .base import LossResult, Method, MethodFacts, ModelFn, euler_sample, guided
from .ddim import DDIM
from .rectified import RectifiedFlow
from .shortcut import Shortcut
from .timesteps import sample_t

METHODS: dict[str, type] = {m.facts.key: m for m in (
    Shortcut, RectifiedFlow, DDIM,
)}
FACTS: dict[str, MethodFacts] = {k: m.facts for k, m in METHODS.items()}
DEFAULT_STEPS = {k: f.default_steps for k, f in FACTS.items()}
MAX_STEPS = {k: f.max_steps for k, f in FACTS.items()}


def method_facts(name: str) -> MethodFacts:
    if name not in FACTS:
        raise ValueError(f"unknown method {name!r}; choose from {', '.join(FACTS)}")
    return FACTS[name]


def make_method(name: str, **kwargs) -> Method:
    return METHODS[method_facts(name).key](**kwargs)


def training_method(name: str, prediction: str = "data", time_sampler: str = "beta") -> Method:
    """The method `name` configured as `gesturelsm train` trains it."""
    return METHODS[method_facts(name).key].for_training(prediction, time_sampler)


def steps_from_flags(steps, ddim_steps, facts: Mapping[str, MethodFacts] | None = None) -> dict:
    """The CLI's and the page's two step settings as steps per method: `--ddim-steps` / the DDIM slider for
    diffusion methods (facts.steps_setting), `--steps` / the steps slider for every other method (the interface the
    README documents). `facts`: the methods to cover (default: this registry). Values are passed on as given: the
    receiver checks them (a page or API value may be anything)."""
    return {k: (ddim_steps if f.steps_setting == "ddim_steps" else steps) for k, f in (facts or FACTS).items()}


def label(name: str) -> str:
    """A method's label for people; other keys (e.g. "ground_truth") are returned as they are."""
    return FACTS[name].label if name in FACTS else name


__all__ = ["LossResult", "Method", "MethodFacts", "ModelFn", "euler_sample", "guided", "DDIM", "RectifiedFlow",
           "Shortcut", "sample_t", "METHODS", "FACTS", "DEFAULT_STEPS", "MAX_STEPS", "method_facts", "make_method",
           "training_method", "steps_from_flags", "label"]
