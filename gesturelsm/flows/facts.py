"""The sampling maths' facts of each method (its most steps, what its sampler asks the network for, whether it takes a
step size), without torch: the command line's parsers and the backend registry read them before any model code
loads. Each method's class (shortcut.py, rectified.py, ddim.py) carries its facts as `facts`."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError

NUM_TRAIN_STEPS = 1000              # DDIM's training noise levels (its most sampling steps)


@dataclass(frozen=True)
class MethodFacts:
    """The sampling maths' facts of a method, beside it (what people see of it and the settings it runs with
    are in its backend registry line, `gesturelsm.backends`)."""
    key: str                         # the name in checkpoints, the CLI and the API, e.g. "gesturelsm"
    max_steps: int                   # the most steps its sampler can take (shortcut: d down to 1/128; DDIM: its
                                     # training steps)
    samples_with: str                # what its sampler asks the model function for: "velocity" | "data" (x1); a
                                     # network's own output is its checkpoint's GeneratorConfig.prediction
    uses_step_size: bool             # whether the network's d input is meaningful


SHORTCUT_FACTS = MethodFacts(key="gesturelsm", max_steps=128, samples_with="velocity", uses_step_size=True)
RECTIFIED_FLOW_FACTS = MethodFacts(key="rectified_flow", max_steps=128, samples_with="velocity", uses_step_size=False)
DDIM_FACTS = MethodFacts(key="ddim", max_steps=NUM_TRAIN_STEPS, samples_with="data", uses_step_size=False)

# the methods in registry order (flows.METHODS holds their classes in the same order)
FACTS: dict[str, MethodFacts] = {f.key: f for f in (SHORTCUT_FACTS, RECTIFIED_FLOW_FACTS, DDIM_FACTS)}


def method_facts(name: str) -> MethodFacts:
    if name not in FACTS:
        raise InputError(f"unknown method {name!r}; choose from {', '.join(FACTS)}")
    return FACTS[name]


__all__ = ["DDIM_FACTS", "FACTS", "MethodFacts", "NUM_TRAIN_STEPS", "RECTIFIED_FLOW_FACTS", "SHORTCUT_FACTS",
           "method_facts"]
