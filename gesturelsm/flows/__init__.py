"""Generative methods behind one interface (see base.py): GestureLSM's shortcut flow matching and the
baselines it is compared with, on the same backbone. Convention: t = 0 noise, t = 1 data."""
from .base import LossResult, Method, ModelFn, guided
from .ddim import DDIM
from .rectified import RectifiedFlow
from .shortcut import Shortcut
from .timesteps import sample_t

METHODS = {"gesturelsm": Shortcut, "rectified_flow": RectifiedFlow, "ddim": DDIM}
DEFAULT_STEPS = {"gesturelsm": 8, "rectified_flow": 8, "ddim": 20}


def make_method(name: str, **kwargs) -> Method:
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; choose from {', '.join(METHODS)}")
    return METHODS[name](**kwargs)


__all__ = ["LossResult", "Method", "ModelFn", "guided", "DDIM", "RectifiedFlow", "Shortcut", "sample_t",
           "METHODS", "DEFAULT_STEPS", "make_method"]
